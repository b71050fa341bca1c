"""The machine check as one section of the results document: the stock and the fixtures asked
(`checker.stock.request.StockRequest`) resolved to solids, the check run
(`checker.collide.check`), its findings added to the summary's counts, status and worst
findings."""

from __future__ import annotations

import numpy as np

from checker.collide.check import DEFAULT_CLEARANCE
from checker.errors import PathcheckError
from checker.results import Finding, MachineResult, ResultsDocument

_WORST = 10


def asked_clearance(machine, clearance: float | None, *, check: str = "--machine-check",
                    clearance_name: str = "--machine-clearance", code: str = "usage") -> float:
    """The clearance of a machine check that is asked (mm; None: `DEFAULT_CLEARANCE`), checked
    before any work: a clearance that is not a distance from 0 to 10000 mm, a machine without
    components, or a missing collision library (code `extra`) is a PathcheckError naming the
    option (`check`, `clearance_name`: the CLI's options or the service's fields)."""
    from checker.extras import require

    if clearance is not None and not (0.0 <= clearance <= 1e4):
        raise PathcheckError(f"{clearance_name} {clearance:g}: expected a distance from 0 to "
                             "10000 mm", code=code)
    if not machine.components:
        raise PathcheckError(f"{check}: machine '{machine.name}' has no components: expected "
                             "[[components]] in its machine file", code=code)
    require("coal", "machine", f"the machine check ({check})")
    return DEFAULT_CLEARANCE if clearance is None else float(clearance)


def machine_section(job, motion, cutters: dict, machine, stock, part_box,
                    clearance: float) -> MachineResult:
    """The `MachineResult` of the written program's `motion` on `machine` (its components
    required), against the part of `job`, the stock and fixtures of `stock` (a StockRequest or
    None); `part_box (2, 3)` or None places a margin stock."""
    from checker.collide.check import check_machine
    from checker.stock.fixtures import load_fixture
    from checker.stock.spec import Box, Cylinder, parse_stock, resolve
    from checker.stock.stated import stated_stock

    if not machine.components:
        raise PathcheckError(f"--machine-check: machine '{machine.name}' has no components: "
                             "expected [[components]] in its machine file", code="usage")
    if not np.isfinite(clearance) or clearance < 0.0:
        raise PathcheckError(f"--machine-clearance {clearance:g}: expected a distance >= 0 mm",
                             code="usage")
    shape, fixtures = None, []
    if stock is not None and stock.stock is not None:
        pts = None if job.triangles is None else job.triangles.vertices
        shape = resolve(parse_stock(stock.stock), part_box, stated_stock(job.toolpath),
                        part_points=pts)
        if not isinstance(shape, Box | Cylinder):
            shape = None  # a solid stock: its mesh is the stock check's (not repeated here)
    if stock is not None:
        fixtures = [load_fixture(text, job.cfg) for text in stock.fixtures]
    return check_machine(machine, motion, cutters, job, clearance=clearance, stock=shape,
                         fixtures=fixtures)


def add_to_document(doc: ResultsDocument, result: MachineResult) -> None:
    """`result` as the document's `machine` section, its findings in the summary."""
    doc.machine = result
    s = doc.summary
    s.counts.machine += len(result.findings)
    if result.findings:
        s.status = "findings"
    extra = [Finding(index=f.index, kind="machine", verdict="machine", line=f.line, op=f.op,
                     tip=(f.axes["X"], f.axes["Y"], f.axes["Z"]), point=None,
                     depth=-f.distance) for f in result.findings]
    s.worst = sorted(s.worst + extra, key=lambda f: -(f.depth or 0.0))[:_WORST]
