"""The check of a job without a part: the program as the CAM wrote it, as the machine makes it,
against the stock and the fixtures (`checker.stock`) and the machine's own solids
(`checker.collide`) alone. Nothing is planned and nothing posted (a corrected program needs
the part). Part frame, mm, degrees."""

from __future__ import annotations

import time

from checker import verdict
from checker.check.checked import Checked
from checker.check.context import context_without_part
from checker.check.document import stated_stock_text, stock_document
from checker.check.options import CheckOptions
from checker.check.program import Program, programmed_motion
from checker.collide.section import add_to_document, machine_section
from checker.errors import PathcheckError
from checker.stock.request import StockRequest
from checker.stock.stock_check import check_stock
from checker.toolpath import ToolPath


def check_without_part(toolpath: ToolPath, options: CheckOptions, t0: float) -> Checked:
    """The program as written against the stock, the fixtures and the machine alone (no
    part): the CAM's own motion; the check began at `t0` (`time.perf_counter`, s)."""
    stock = options.stock or StockRequest()
    if options.to_post:
        raise PathcheckError("a check without a part does not post: the corrected program needs "
                             "the part (give --part, or drop -o)", code="usage")
    if stock.deviation_out is not None:
        raise PathcheckError("--deviation-out compares the machined part with the part: "
                             "expected a part (give --part)", code="usage")
    job = context_without_part(toolpath, options)
    motion = programmed_motion(job)
    checked = check_stock(job, motion, job.cutters, job.tolerance, stock, None)
    doc = stock_document(job, motion, checked, t0)
    if options.machine_clearance is not None:
        add_to_document(doc, machine_section(job, motion, job.cutters, job.machine, stock, None,
                                             options.machine_clearance))
        doc.summary.time_s = time.perf_counter() - t0
    doc.job.stated_stock = stated_stock_text(toolpath, None)
    program = Program(job.m.tip, job.m.axis, job.cam_b(), None, None,
                      {o: "as-programmed" for o in job.classes}, stock=checked)
    counts = {v: int(getattr(doc.summary.counts, v)) for v in verdict.FINDINGS}
    return Checked(doc, job, program, job.machine, job.cutters, counts, t0)
