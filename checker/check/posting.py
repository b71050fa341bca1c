"""Posting, the stage after the check: the checked program written as G-code for its machine
(`postproc.post.post_toolpath`) under a policy on findings, or a CL file posted without a check.
The check (`checker.check.job`) hands over what is to be written (`checked.Checked`); posting
is done only when a caller asks for G-code. Part frame, mm, degrees."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from checker import verdict as vd
from checker.apt import read_cl
from checker.check.checked import Checked, infeasible_rows
from checker.check.context import JobContext
from checker.check.inputs import job_config, operation_cutters
from checker.check.options import ON_FINDINGS
from checker.check.program import Program
from checker.errors import PathcheckError
from checker.postproc.header import verdict_text
from checker.postproc.post import post_toolpath
from checker.progress import step

__all__ = ["ON_FINDINGS", "PostRefusedError", "flags", "post_checked", "post_unchecked"]


class PostRefusedError(Exception):
    """The program was not written (``--on-findings refuse``): ``counts`` the findings of the
    program as written (`checked.written_counts`), ``document`` the check that ran."""

    def __init__(self, counts: dict[str, int], document=None) -> None:
        self.counts = counts
        self.document = document
        super().__init__("the program has " + ", ".join(f"{k} {n}" for k, n in counts.items()
                                                        if n))


def post_checked(checked: Checked, output, on_findings: str = "refuse") -> Path:
    """Write the checked program to `output` (`doc.gcode` names it) with its header (every
    cutter, the verdict from the counts) and what is wrong before each offending move (its
    findings, a machine collision starting on it: `_with_machine`): a comment (``comment``), a
    comment and an optional stop M01 (``stop``); ``refuse`` writes nothing when any count,
    machine collisions included, is non-zero (PostRefusedError). A multi-axis program cannot
    be posted for a B-table machine. An error carries the check that ran (``err.document``, so
    that the caller may still record it); the document's time includes posting."""
    doc = checked.document
    try:
        with step("post the G-code"):
            doc.gcode = str(_post(checked, output, on_findings))
    except (PathcheckError, PostRefusedError) as err:
        err.document = doc
        raise
    finally:
        doc.summary.time_s = time.perf_counter() - checked.started
    return Path(doc.gcode)


def _post(checked: Checked, output, on_findings: str):
    job, program = checked.job, checked.program
    if np.isnan(program.b).any() and len(checked.machine.rotary_axes) < 2:
        bad = int(job.m.line[np.flatnonzero(np.isnan(program.b))[0]])
        raise PathcheckError("cannot post a multi-axis path for a 4-axis machine: expected tool "
                             "axes perpendicular to Y (j = 0)", path=job.apt_path, line=bad,
                             code="not-4-axis")
    if on_findings not in ON_FINDINGS:
        raise PathcheckError(f"on_findings '{on_findings}': expected one of "
                             f"{', '.join(ON_FINDINGS)}", code="usage")
    if on_findings == "refuse" and any(checked.counts.values()):
        raise PostRefusedError(checked.counts)
    comments = _with_machine(flags(job, program), checked.document)
    stops = np.array([bool(c) for c in comments]) if on_findings == "stop" else None
    return post_toolpath(job.toolpath, output, machine=checked.machine, b_deg=program.b,
                         comments=comments, stops=stops,
                         arc_chord_tol=job.cfg.check.arc_chord_tolerance, tip=program.tip,
                         cutters=checked.cutters, verdict=verdict_text(checked.counts),
                         axes=program.axis)


def flags(job: JobContext, program: Program) -> list[str]:
    """Per motion row the comment written before it ('' none): a finding at its pose (the
    first), a finding along the move that reaches it (the first), no feasible B at it."""
    w = program.written
    at: dict[int, list[str]] = {}
    for rows, verdict, depth, where in (
            (w.moves.row, w.pose_verdict, w.poses.depth, "CL LINE {line}"),
            (w.moves.row[w.along.end], w.move_verdict, w.along.depths.depth, "ALONG THE MOVE")):
        hit = np.flatnonzero(vd.is_finding(verdict))
        _, first = np.unique(rows[hit], return_index=True)
        for i in hit[first]:
            row = int(rows[i])
            at.setdefault(row, []).append(f"{str(verdict[i]).upper()} "
                                          f"{where.format(line=int(job.m.line[row]))} "
                                          f"DEPTH {depth[i]:.4f}")
    if program.stock is not None:
        st = program.stock
        hit = np.flatnonzero(vd.is_finding(st.verdict))
        for i in hit:
            row = int(w.moves.row[i])
            at.setdefault(row, []).append(f"{str(st.verdict[i]).upper()} INTO "
                                          f"{str(st.against[i]).upper()} DEPTH {st.depth[i]:.4f}")
    for row in infeasible_rows(program).tolist():
        at.setdefault(int(row), []).append("NO FEASIBLE B")
    out = [""] * len(job.m)
    for row, texts in at.items():
        out[row] = "PATHCHECK " + "; ".join(texts)
    return out


def _with_machine(comments: list[str], doc) -> list[str]:
    """`comments` (per motion row, `flags`) with each machine finding of `doc`
    (`checker.collide`) before the move where it starts: its two solids and the least distance
    of its run (mm, < 0: into each other)."""
    found = [] if doc.machine is None else doc.machine.findings
    out = list(comments)
    for f in found:
        text = f"MACHINE {f.a.upper()} / {f.b.upper()} LEAST {f.distance:.4f}"
        out[f.move] = f"{out[f.move]}; {text}" if out[f.move] else f"PATHCHECK {text}"
    return out


def post_unchecked(apt_path, output, cutter=None, machine=None, config=None,
                   cutter_units: str | None = None) -> Path:
    """Post a job without checking it (no part needed): the CL's own tool axes (the machine's
    inverse kinematics finds the rotary words, B on a 4-axis table), every operation's cutter
    (or `cutter`, a `Cutter` or "CUTTER/..." read in `cutter_units`, default the job's) in the
    header, which says NOT CHECKED. Returns the path written."""
    cfg = job_config(config)
    toolpath = read_cl(Path(apt_path), require_cutter=False)
    ops = np.arange(len(toolpath.operations))
    cutters = None if cutter is None else operation_cutters(toolpath, ops, cutter,
                                                            Path(apt_path), cutter_units)
    with step("post the G-code"):
        return post_toolpath(toolpath, output, machine=machine, cutters=cutters,
                             arc_chord_tol=cfg.check.arc_chord_tolerance)
