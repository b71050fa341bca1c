"""The program that is written, and the real tool along it.

Per operation, by its axis class: 3-axis and indexed operations are written as programmed (an
indexed operation keeps its one B). A 4-axis operation (or a 3-axis one asked to be
re-oriented) gets a B per cutting pose from the allowable-cutter engine (`checker.four_axis`:
best B, feasible intervals, shortest path), its other moves following the nearest cutting pose;
A multi-axis operation asked to be re-oriented gets an axis per contact pose, by the strategy
asked: inside its feasible set (`allowable`, `checker.five_axis.plan`) or the flat-end's
highest-order contact (`contact-order`, `checker.five_axis.contact_plan`), its other moves
following the nearest contact pose. That program is checked, and where it does not have fewer
findings than the CAM's own angles, the CAM's are written instead: a corrected program is never
worse. What is written is what is checked, verdicted and reported. Part frame, mm, degrees."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from checker import verdict as vd
from checker.b_axis import axis_for_b, b_for_axis, rotate_about_y
from checker.errors import PathcheckError
from checker.five_axis.machine_motion import machine_path
from checker.four_axis.b_plan import plan_b
from checker.geometry.contact import cl_to_cc, contact_from_toolpath
from checker.mesh.tool import tool_pieces
from checker.moves import RAPID, START, Moves, machine_moves
from checker.verify import Depths, MoveDepths, ProgramMotion, tool_depths

STRATEGIES = ("allowable", "contact-order")  # the multi-axis planners of --reorient


@dataclass
class Verified:
    """The real tool along one version of the motions: the poses and moves (`moves`), the
    depths at every pose and along every move (`along`, per move end), their verdicts and the
    tolerance of each pose and move (the operation's plus the part's deviation near the deepest
    point)."""

    moves: Moves
    poses: Depths
    along: MoveDepths
    pose_verdict: np.ndarray
    move_verdict: np.ndarray
    tolerance: np.ndarray
    move_tolerance: np.ndarray
    motion: ProgramMotion | None = None

    def findings(self, poses: np.ndarray) -> int:
        """Findings at the poses `poses` and along the moves that reach them."""
        at_move = np.isin(self.along.end, poses)
        return int(vd.is_finding(self.pose_verdict[poses]).sum()
                   + vd.is_finding(self.move_verdict[at_move]).sum())


@dataclass
class Plan:
    """A planned (4-axis) operation: its cutting rows, contacts, orientations (best, chosen)
    and what the planned program is."""

    rows: np.ndarray
    contacts: object
    orientations: object
    b_rows: np.ndarray
    tip_rows: np.ndarray


@dataclass
class Program:
    """The written program: per motion row its tip, axis and table angle B (nan: none), the
    real tool along it (`written`), along the CAM's own motions (`cam`, when any operation was
    re-oriented), per operation how it was handled, and the plans of planned operations."""

    tip: np.ndarray
    axis: np.ndarray
    b: np.ndarray
    written: Verified
    cam: Verified | None
    handling: dict[int, str]
    plans: dict[int, Plan] = field(default_factory=dict)
    fives: dict[int, object] = field(default_factory=dict)  # multi-axis: `five_axis.plan`
    stock: object = None  # against the stock and the fixtures: `checker.stock.check.StockCheck`


def program_motion(job, tip: np.ndarray, axis: np.ndarray, b: np.ndarray,
                   center: np.ndarray) -> ProgramMotion:
    """The poses and moves of the motions (tips, axes, table angles `b` per motion row, nan:
    none) as the machine makes them; multi-axis operations on a 5-axis machine run its joints
    linearly."""
    moves = machine_moves(replace(job.m, tip=tip, axis=axis))
    five = getattr(job, "motion", None)
    path = None if five is None else machine_path(five, axis, job.m.line, str(job.apt_path),
                                                  moves.row, moves.tip)
    return ProgramMotion(moves, job.m.op[moves.row], b[moves.row], np.asarray(center, float),
                         path, frozenset() if five is None else frozenset(five.ops))


def verify(job, tip: np.ndarray, axis: np.ndarray, b: np.ndarray, cutters: dict, tol,
           center: np.ndarray) -> Verified:
    """The real tool at every pose of the motions (tips, axes per motion row) and along every
    move; rows with a table angle `b` (not nan) move linearly in machine X Y Z B."""
    cfg = job.cfg
    motion = program_motion(job, tip, axis, b, center)
    moves = motion.moves
    tolerance = tol.value[motion.op_of]
    v = job.triangles.vertices
    box = np.array([v.min(axis=0), v.max(axis=0)]) + [[-cfg.check.reach], [cfg.check.reach]]
    pieces = {o: tool_pieces(cutters[o], with_holder=True) for o in np.unique(motion.op_of)}
    poses, along = tool_depths(job.index, box, motion, pieces, tolerance, cfg.check.reach)
    near = _near(job, moves, cutters, poses.height)
    rapid_pose = (moves.kind == RAPID) | ((moves.kind == START) & job.m.rapid[moves.row])
    local = _local_deviation(job, poses.triangle)
    pose_verdict = vd.decide(poses.depth, poses.piece, rapid_pose, near, tolerance + local)
    move_near = _near(job, moves, cutters, along.depths.height, along.end)
    move_tol = tolerance[along.end] + _local_deviation(job, along.depths.triangle)
    # the depth is continuous: a move whose end pose penetrates penetrates next to it too, at
    # least within the tolerance where the poses checked along it found nothing deeper
    touching = np.maximum(poses.depth[along.end - 1], poses.depth[along.end])
    move_verdict = vd.decide(np.maximum(along.depths.depth, np.minimum(touching, move_tol)),
                             along.depths.piece,
                             (moves.kind[along.end] == RAPID) & ~moves.retract[along.end],
                             move_near, move_tol)
    return Verified(moves, poses, along, pose_verdict, move_verdict, tolerance + local, move_tol,
                    motion)


def _local_deviation(job, triangle: np.ndarray) -> np.ndarray:
    """The deviation of the part's triangles from its surfaces at the deepest triangles
    (0 where there is none)."""
    dev = job.triangles.deviation
    return np.where(triangle >= 0, dev[np.maximum(triangle, 0)], 0.0)


def _near(job, moves: Moves, cutters: dict, height: np.ndarray, at: np.ndarray | None = None):
    """Whether the deepest point is on the cutting end of the cutter (within
    `check.gouge_neighbourhood` radii of the tip): where a penetration is a gouge."""
    at = np.arange(len(moves)) if at is None else at
    op_of = job.m.op[moves.row[at]]
    reach = np.array([job.cfg.check.gouge_neighbourhood * 0.5 * cutters[int(o)].d
                      for o in op_of]) if len(at) else np.zeros(0)
    return np.nan_to_num(height, nan=np.inf) <= reach


def check_frames(job, verified: Verified, cutters: dict) -> None:
    """A part in another frame than its path: most cutting poses deep inside it. The depth
    into the part's surface saturates at the cutter's inradius when a pose is buried (the
    deepest point of the surface inside the cutter is at most a radius from its side), so deep
    means more than half the cutter radius. One line with the boxes and their offset, instead
    of a finding per pose."""
    mv = verified.moves
    cutting = np.flatnonzero((mv.kind != RAPID) & ~mv.hole & ~job.m.rapid[mv.row])
    if len(cutting) < 10:
        return
    radius = np.array([0.5 * cutters[int(o)].d for o in job.m.op[mv.row[cutting]]])
    deep = verified.poses.depth[cutting] > 0.5 * radius
    share = float(deep.mean())
    if share < job.cfg.check.misaligned_fraction:
        return
    path_box = np.array([mv.tip[cutting].min(axis=0), mv.tip[cutting].max(axis=0)])
    part_box = np.array([job.triangles.vertices.min(axis=0), job.triangles.vertices.max(axis=0)])
    off = path_box.mean(axis=0) - part_box.mean(axis=0)
    fmt = lambda v: "(" + ", ".join(f"{x:.3f}" for x in v) + ")"  # noqa: E731
    raise PathcheckError(
        f"part and path do not line up: {share:.0%} of the cutting poses are deeper in the part "
        f"than half the cutter radius; path box {fmt(path_box[0])}..{fmt(path_box[1])}, part box "
        f"{fmt(part_box[0])}..{fmt(part_box[1])}, centres offset by {fmt(off)} mm: give "
        f"--part-transform with the part's placement in the CL frame",
        path=job.apt_path, code="frames")


def cutting_rows(job, rows: np.ndarray) -> np.ndarray:
    """Of the motion rows `rows`, the cutting ones: feed moves that are not canned-cycle
    holes (the advice and the B planning are for them)."""
    m = job.m
    return rows[~m.rapid[rows] & ~m.cycle[rows]]


def _plan(job, o: int, cutter, b_range, mach) -> Plan | None:
    """The 4-axis plan of operation o (NURBS parts: the allowable-cutter engine), or None
    where there is nothing to plan (no cutting rows, or a mesh part)."""
    m = job.m
    rows = cutting_rows(job, np.flatnonzero(m.op == o))
    if rows.size == 0 or not job.part.surfaces:
        return None
    samples = job.test_points()
    given = contact_from_toolpath(job.toolpath, m.line[rows])
    con = cl_to_cc(job.part, samples, cutter, m.tip[rows], m.axis[rows], contact=given)
    orient, b_chosen, tips_chosen = plan_b(
        test_points=samples, part=job.part, cutter=cutter, contacts=con, tips=m.tip[rows],
        axes=m.axis[rows], lines=m.line[rows], b_range=b_range,
        machine_limits=_limits(mach), path=str(job.apt_path), cfg=job.cfg)
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


def _limits(mach) -> tuple[float, float]:
    if mach is not None and mach.rotary.wrap == "limited":
        return mach.rotary.b_min, mach.rotary.b_max
    return -360.0, 360.0


def _center(mach) -> np.ndarray:
    return np.zeros(3) if mach is None else np.asarray(mach.kinematics.table_center, float)


def cam_b(job) -> np.ndarray:
    """The CAM's table angle B per motion row (degrees; nan where the axis is not in the XZ
    plane)."""
    j_ok = np.abs(job.m.axis[:, 1]) <= job.cfg.four_axis.axis_j_tolerance
    return np.where(j_ok, b_for_axis(job.m.axis), np.nan)


def _five_plan(job, o: int, cutter, tolerance: float, strategy: str):
    """The 5-axis plan of multi-axis operation o by `strategy` ("allowable": `five_axis.plan`,
    "contact-order": `five_axis.contact_plan`), or None."""
    from checker.five_axis.contact_plan import plan_contact_order
    from checker.five_axis.reorient import plan_operation

    op_rows = np.flatnonzero(job.m.op == o)
    # the job's 5-axis motion carries the machine's chain (None: fewer than two rotary axes)
    chain = job.motion.chain if getattr(job, "motion", None) is not None else None
    planner = plan_contact_order if strategy == "contact-order" else plan_operation
    return planner(job, cutting_rows(job, op_rows), op_rows, cutter, tolerance, chain, job.cfg)


def programmed_motion(job, classes: dict, mach) -> ProgramMotion:
    """The program as the CAM wrote it, as the machine makes it (its 4-axis moves turning the
    table), for a check without a part: against the stock and the fixtures alone."""
    turning = np.isin(job.m.op, [o for o, c in classes.items() if c == "4-axis-Y"])
    b_move = np.where(turning, cam_b(job), np.nan)
    return program_motion(job, job.m.tip, job.m.axis, b_move, _center(mach))


def plan_program(job, cutters: dict, classes: dict, planned: set, tol, b_range, mach,
                 reoriented: set = frozenset(), strategy: str = "allowable") -> Program:
    """The program to write and the real tool along it (see the module docstring); `planned`
    the 4-axis operations to plan B for, `reoriented` the multi-axis ones to re-orient by
    `strategy` (`STRATEGIES`)."""
    m = job.m
    center = _center(mach)
    b_cam = cam_b(job)
    turning = np.isin(m.op, [o for o, c in classes.items() if c == "4-axis-Y"])
    b_move = np.where(turning, b_cam, np.nan)  # the CAM's 4-axis moves turn the table too
    cam = verify(job, m.tip, m.axis, b_move, cutters, tol, center)
    check_frames(job, cam, cutters)
    handling = {o: "as-programmed" for o in classes}
    plans, fives = {}, {}
    for o in sorted(planned):
        p = _plan(job, o, cutters[o], b_range, mach)
        if p is not None:
            plans[o] = p
    for o in sorted(reoriented):
        p = _five_plan(job, o, cutters[o], float(tol.value[o]), strategy)
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
    new = verify(job, tip, axis, b_turn, cutters, tol, center)
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
        new = verify(job, tip, axis, b_turn, cutters, tol, center)
    return Program(tip, axis, b, new, cam, handling, plans, fives)


@dataclass
class Checked:
    """A checked job and what is to be written: its results `document`, the `job` (motions,
    part, config), the `program` as written, the `machine` (None when neither planning nor
    posting needed one), every operation's cutter, `counts` the findings of the program as
    written (`written_counts`) and `started` when the check began (`time.perf_counter`, s)."""

    document: object
    job: object
    program: Program
    machine: object
    cutters: dict
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


def written_counts(counts, program: Program) -> dict[str, int]:
    """What the program as written has against it: the document's finding counts (``counts``,
    its poses and moves) and its points without a feasible B."""
    out = {v: int(getattr(counts, v)) for v in vd.FINDINGS}
    out["no feasible B"] = int(infeasible_rows(program).size)
    return out


def flags(job, program: Program) -> list[str]:
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
