"""The program that is written, and the real tool along it.

Per operation, by its axis class: 3-axis and indexed operations are written as programmed (an
indexed operation keeps its one B). A 4-axis operation (or a 3-axis one asked to be
re-oriented) gets a B per cutting pose from the allowable-cutter engine (`checker.four_axis`:
best B, feasible intervals, shortest path), its other moves following the nearest cutting pose;
a multi-axis operation asked to be re-oriented gets an axis per contact pose, by the strategy
asked: inside its feasible set (`allowable`, `checker.five_axis.reorient`) or the flat-end's
highest-order contact (`contact-order`, `checker.five_axis.contact_plan`), its other moves
following the nearest contact pose. That program is checked (`checker.check.verified`), and
where it does not have fewer findings than the CAM's own angles, the CAM's are written instead:
a corrected program is never worse. What is written is what is checked, verdicted and
reported. Part frame, mm, degrees."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from checker.b_axis import axis_for_b, b_for_axis, rotate_about_y
from checker.check.context import JobContext
from checker.check.verified import Verified, check_frames, program_motion, verify_motions
from checker.cutter import Cutter
from checker.four_axis.b_plan import plan_b
from checker.geometry.contact import Contacts, cl_to_cc, contact_from_toolpath

if TYPE_CHECKING:
    from checker.five_axis.reorient import FivePlan
    from checker.four_axis.over_b import Orientations
    from checker.postproc.machine import Machine
    from checker.stock.stock_check import StockCheck
    from checker.verify import ProgramMotion


@dataclass
class Plan:
    """A planned (4-axis) operation: its cutting rows `rows (K,)`, their contacts (CL -> CC at
    the CAM's B), the table angles per contact (`orientations`: the CAM's, the best, the
    chosen and the greedy one, `four_axis.over_b`), and per row of the operation the planned
    table angle `b_rows` (degrees) and tip `tip_rows` (mm, part frame)."""

    rows: np.ndarray
    contacts: Contacts
    orientations: Orientations
    b_rows: np.ndarray
    tip_rows: np.ndarray


@dataclass
class Program:
    """The written program: per motion row its tip, axis and table angle B (nan: none), the
    real tool along it (`written`; None in a check without a part, `without_part`), along the
    CAM's own motions (`cam`, when any operation was re-oriented), per operation how it was
    handled, the plans of planned operations and the stock check along it."""

    tip: np.ndarray
    axis: np.ndarray
    b: np.ndarray
    written: Verified | None
    cam: Verified | None
    handling: dict[int, str]
    plans: dict[int, Plan] = field(default_factory=dict)
    fives: dict[int, FivePlan] = field(default_factory=dict)  # multi-axis: `five_axis.reorient`
    stock: StockCheck | None = None  # against the stock and the fixtures (`checker.stock`)


def _plan(job: JobContext, o: int) -> Plan | None:
    """The 4-axis plan of operation o (NURBS parts: the allowable-cutter engine), or None
    where there is nothing to plan (no cutting rows, or a mesh part)."""
    m, cutter = job.m, job.cutters[o]
    rows = job.cutting_rows(np.flatnonzero(m.op == o))
    if rows.size == 0 or not job.part.surfaces:
        return None
    samples = job.test_points()
    given = contact_from_toolpath(job.toolpath, m.line[rows])
    con = cl_to_cc(job.part, samples, cutter, m.tip[rows], m.axis[rows], contact=given)
    orient, b_chosen, tips_chosen = plan_b(
        test_points=samples, part=job.part, cutter=cutter, contacts=con, tips=m.tip[rows],
        axes=m.axis[rows], lines=m.line[rows], b_range=job.options.b_range,
        machine_limits=_limits(job.machine), path=str(job.apt_path), cfg=job.cfg)
    op_rows = np.flatnonzero(m.op == o)
    # every row of the operation follows its nearest cutting row, moved with it
    k = np.clip(np.searchsorted(rows, op_rows), 0, len(rows) - 1)
    prev = np.clip(k - 1, 0, len(rows) - 1)
    k = np.where(np.abs(rows[prev] - op_rows) < np.abs(rows[k] - op_rows), prev, k)
    b_old = b_for_axis(m.axis[rows[k]])
    b_new = b_chosen[k]
    tip = tips_chosen[k] + rotate_about_y(m.tip[op_rows] - m.tip[rows[k]], b_old - b_new,
                                          np.zeros(3))
    tip[np.searchsorted(op_rows, rows)] = tips_chosen
    return Plan(rows, con, orient, b_new, tip)


def _limits(mach: Machine | None) -> tuple[float, float]:
    """The table's B limits (degrees) where it has them, else one turn either way."""
    if mach is not None and mach.rotary.wrap == "limited":
        return mach.rotary.b_min, mach.rotary.b_max
    return -360.0, 360.0


def _five_plan(job: JobContext, o: int, cutter: Cutter) -> FivePlan | None:
    """The 5-axis plan of multi-axis operation o by the strategy asked ("allowable":
    `five_axis.reorient`, "contact-order": `five_axis.contact_plan`), or None."""
    from checker.five_axis.contact_plan import plan_contact_order
    from checker.five_axis.reorient import plan_operation

    op_rows = np.flatnonzero(job.m.op == o)
    # the job's 5-axis motion carries the machine's chain (None: fewer than two rotary axes)
    chain = job.motion.chain if job.motion is not None else None
    planner = plan_contact_order if job.options.strategy == "contact-order" else plan_operation
    return planner(job, job.cutting_rows(op_rows), op_rows, cutter,
                   float(job.tolerance.value[o]), chain, job.cfg)


def _cam_turning(job: JobContext) -> np.ndarray:
    """The CAM's table angle B per motion row where its 4-axis moves turn the table (degrees,
    nan elsewhere)."""
    turning = np.isin(job.m.op, [o for o, c in job.classes.items() if c == "4-axis-Y"])
    return np.where(turning, job.cam_b(), np.nan)


def programmed_motion(job: JobContext) -> ProgramMotion:
    """The program as the CAM wrote it, as the machine makes it (its 4-axis moves turning the
    table), for a check without a part: against the stock and the fixtures alone."""
    return program_motion(job, job.m.tip, job.m.axis, _cam_turning(job))


def plan_program(job: JobContext) -> Program:
    """The program to write and the real tool along it (see the module docstring): B planned
    for the operations `job.planned`, the multi-axis ones `job.reoriented` re-oriented by the
    strategy asked."""
    m = job.m
    b_cam = job.cam_b()
    b_move = _cam_turning(job)  # the CAM's 4-axis moves turn the table too
    cam = verify_motions(job, m.tip, m.axis, b_move)
    check_frames(job, cam)
    handling = {o: "as-programmed" for o in job.classes}
    plans: dict[int, Plan] = {}
    fives: dict[int, FivePlan] = {}
    for o in sorted(job.planned):
        p = _plan(job, o)
        if p is not None:
            plans[o] = p
    for o in sorted(job.reoriented):
        p = _five_plan(job, o, job.cutters[o])
        if p is not None:
            fives[o] = p
    if not plans and not fives:
        return Program(m.tip, m.axis, b_cam, cam, None, handling)
    tip, axis, b = m.tip.copy(), m.axis.copy(), b_cam.copy()
    b_turn = b_move.copy()
    for o, p in plans.items():
        op_rows = np.flatnonzero(m.op == o)
        tip[op_rows], b[op_rows], b_turn[op_rows] = p.tip_rows, p.b_rows, p.b_rows
        axis[op_rows] = axis_for_b(p.b_rows)
    for p in fives.values():
        tip[p.op_rows], axis[p.op_rows] = p.tip_rows, p.axis_rows
        b[p.op_rows] = b_turn[p.op_rows] = np.nan
    new = verify_motions(job, tip, axis, b_turn)
    for o in [*plans, *fives]:
        mine_new = np.flatnonzero(job.m.op[new.moves.row] == o)
        mine_cam = np.flatnonzero(job.m.op[cam.moves.row] == o)
        planned_n, cam_n = new.findings(mine_new), cam.findings(mine_cam)
        if planned_n < cam_n or planned_n == cam_n == 0:
            handling[o] = "re-oriented"
            continue
        handling[o] = "cam-kept"
        op_rows = np.flatnonzero(m.op == o)
        tip[op_rows], axis[op_rows], b[op_rows] = m.tip[op_rows], m.axis[op_rows], b_cam[op_rows]
        b_turn[op_rows] = b_move[op_rows]
    if all(h != "re-oriented" for h in handling.values()):
        return Program(m.tip, m.axis, b_cam, cam, None, handling, plans, fives)
    if any(h == "cam-kept" for h in handling.values()):
        new = verify_motions(job, tip, axis, b_turn)
    return Program(tip, axis, b, new, cam, handling, plans, fives)


