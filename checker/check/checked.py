"""What the check hands over to posting and to its callers (`Checked`): the results document,
the job context, the program as written, its machine and cutters, and the findings of the
program as written, counted once (`written_counts`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker import verdict as vd
from checker.check.context import JobContext
from checker.check.program import Program
from checker.cutter import Cutter
from checker.postproc.machine import Machine
from checker.results import ResultsDocument, VerdictCounts


@dataclass
class Checked:
    """A checked job and what is to be written: its results `document`, the `job` context
    (motions, part, config, options), the `program` as written, the `machine` (None when
    neither planning, posting nor the machine check needed one), every operation's cutter,
    `counts` the findings of the program as written (`written_counts`) and `started` when the
    check began (`time.perf_counter`, s)."""

    document: ResultsDocument
    job: JobContext
    program: Program
    machine: Machine | None
    cutters: dict[int, Cutter]
    counts: dict[str, int]
    started: float


def infeasible_rows(program: Program) -> np.ndarray:
    """Motion rows whose written B is a re-oriented operation's chosen B where no B is feasible
    (the allowable cutter is smaller than the real one at every B), and a re-oriented
    multi-axis operation's contact rows where no tool axis is feasible."""
    rows = [p.rows[~np.asarray(p.orientations.chosen.feasible, bool)]
            for o, p in program.plans.items() if program.handling[o] == "re-oriented"]
    rows += [p.rows[~np.asarray(p.chosen.feasible, bool)]
             for o, p in program.fives.items() if program.handling[o] == "re-oriented"]
    return np.concatenate(rows) if rows else np.zeros(0, dtype=int)


def written_counts(counts: VerdictCounts, program: Program) -> dict[str, int]:
    """What the program as written has against it: the document's finding counts (``counts``,
    its poses and moves) and its points without a feasible B."""
    out = {v: int(getattr(counts, v)) for v in vd.FINDINGS}
    out["no feasible B"] = int(infeasible_rows(program).size)
    return out
