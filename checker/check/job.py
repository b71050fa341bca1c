"""The check of a job, stage by stage, shared by the CLI, the service and batch runs:
1. the context (`context.job_context`): the CL file's motions, the part, its triangles and
   their index, every operation's cutter, tolerance and axis class, the machine;
2. the program to write (`program.plan_program`): per operation by its axis class, as
   programmed, B planned (4-axis) or re-oriented (multi-axis), the CAM's kept where planning
   does not remove its findings, and the real tool at every pose and along every move with
   the one verdict rule (`verified`);
3. the stock and the fixtures along it when asked (`checker.stock`);
4. the advice at the cutting poses (`advice.advise`: contact, allowable cutter, margin, best
   B) and the rotary motion (`rotary.rotary_motion`);
5. the results document assembled from them (`document.build_document`), with the machine's
   solids when asked (`checker.collide`); `check_program` stops here and returns what is to
   be written (`checked.Checked`);
6. posting, when G-code is asked for (`posting.post_checked`).
Without a part, the program is checked against the stock, the fixtures and the machine alone
(`without_part`). Part frame, mm, degrees."""

from __future__ import annotations

import time
from pathlib import Path

from checker.apt import read_cl
from checker.check.advice import advise
from checker.check.checked import Checked, written_counts
from checker.check.context import job_context
from checker.check.document import build_document, stated_stock_text
from checker.check.options import CheckOptions
from checker.check.posting import post_checked
from checker.check.program import plan_program
from checker.check.rotary import rotary_motion
from checker.check.without_part import check_without_part
from checker.collide.section import add_to_document, machine_section
from checker.geometry import find_part_beside
from checker.progress import step
from checker.results import ResultsDocument
from checker.stock.stock_check import check_stock
from checker.toolpath import ToolPath

_DEFAULTS = CheckOptions()


def check_job(apt_path: str | Path, part_path: str | Path | None = None,
              options: CheckOptions = _DEFAULTS) -> ResultsDocument:
    """Check a job: `apt_path` the CL file; `part_path` the part (default: the file beside the
    job with the same stem); `options` how (`CheckOptions`: the cutter, the machine, the
    config, planning, the stock, the machine check, the G-code to post and the policy on
    findings). Returns the results document (`summary.status` is the one answer)."""
    t0 = time.perf_counter()
    with step("read the CL file"):
        toolpath = read_cl(Path(apt_path), require_cutter=options.cutter is None)
    return check_toolpath(toolpath, part_path, options, started=t0)


def check_toolpath(toolpath: ToolPath, part_path: str | Path | None = None,
                   options: CheckOptions = _DEFAULTS, *,
                   started: float | None = None) -> ResultsDocument:
    """`check_job` on a tool path already in memory (read from a CL file, or from a G-code
    program by `pathcheck check-gcode`); `toolpath.path` names the job; `started` when the
    check began (`time.perf_counter`, s; default now). With `options.output`, the checked
    program is posted there under `options.on_findings` (`posting.post_checked`: refuse raises
    `posting.PostRefusedError`)."""
    checked = check_program(toolpath, part_path, options, started=started)
    if options.output is not None:
        post_checked(checked, options.output, options.on_findings)
    return checked.document


def check_program(toolpath: ToolPath, part_path: str | Path | None = None,
                  options: CheckOptions = _DEFAULTS, *, started: float | None = None) -> Checked:
    """The check of `check_toolpath` without posting (stages 1-5 of the module docstring): the
    results document and what is to be written (the program, its machine, cutters and finding
    counts). With `options.output` the program is to be posted, so its machine is resolved
    even when no operation is planned."""
    t0 = time.perf_counter() if started is None else started
    clearance = options.machine_clearance
    if part_path is None and (options.stock_asked or clearance is not None) \
            and find_part_beside(Path(toolpath.path)) is None:
        return check_without_part(toolpath, options, t0)
    job = job_context(toolpath, part_path, options)
    with step("plan and check the program"):
        program = plan_program(job)
    if options.stock_asked:
        program.stock = check_stock(job, program.written.motion, job.cutters, job.tolerance,
                                    options.stock, job.part_box)
    with step("advice at the cutting poses"):
        advice = advise(job, program)
        rotary = rotary_motion(job, program)
    doc = build_document(job, program, advice, rotary, t0)
    if clearance is not None:
        add_to_document(doc, machine_section(job, program.written.motion, job.cutters,
                                             job.machine, options.stock, job.part_box,
                                             clearance))
    doc.summary.time_s = time.perf_counter() - t0
    doc.job.stated_stock = stated_stock_text(toolpath, job.part_box)
    counts = written_counts(doc.summary.counts, program)
    return Checked(doc, job, program, job.machine, job.cutters, counts, t0)
