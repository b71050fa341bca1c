"""The results document of a checked job, assembled from the results of the stages before it:
the program that is written and the real tool along it (`checker.check.program`), the advice
(`checker.check.advice`) and the rotary motion (`checker.check.rotary`). A point per pose at a
CL record or a canned-cycle hole, a point per move that penetrates somewhere along its length
(at its deepest pose), the advice at the cutting poses (contact, allowable cutter, margin;
4-axis: best B and feasible B; re-oriented multi-axis: the axis's lead and tilt and, by the
allowable planner, the feasible set as bits of the operation's grid), per operation what was
done with it (and how a multi-axis one was planned), and the summary whose status is the one
answer. Nothing is computed here beyond counting and formatting. mm, degrees, part frame."""

from __future__ import annotations

import time

import numpy as np

from checker import verdict as vd
from checker.check.advice import Advice
from checker.check.context import JobContext
from checker.check.program import Program
from checker.check.rotary import RotaryMotion, reoriented_fives
from checker.check.verified import Verified, pose_of_rows
from checker.moves import RAPID
from checker.results import (
    ContactOrder,
    FeasibleGrid,
    Finding,
    JobInfo,
    OperationResult,
    Orientation,
    PointResult,
    ResultsDocument,
    Summary,
    VerdictCounts,
)
from checker.results import verdict_counts as counts
from checker.stock.stock_check import StockCheck
from checker.toolpath import ToolPath
from checker.verify import ProgramMotion

_WORST = 10
_PIECES = ("body", "shank", "holder")


def _opt(x) -> float | None:
    return float(x) if x is not None and np.isfinite(x) else None


def _vec(v) -> tuple[float, float, float] | None:
    return tuple(float(x) for x in v) if v is not None and np.isfinite(v).all() else None


def _five_points(program: Program) -> dict[int, dict]:
    """Per contact row of a re-oriented multi-axis operation: the written axis's lead and tilt
    (degrees), its feasible grid nodes (base64 bits) and the count of boundary crossings."""
    import base64

    out: dict[int, dict] = {}
    for p in reoriented_fives(program).values():
        for k, row in enumerate(p.rows.tolist()):
            out[row] = dict(lead=float(np.degrees(p.lead[k])), tilt=float(np.degrees(p.tilt[k])))
        if p.region is None:  # the contact-order planner: no feasible sets
            continue
        packed = p.region.packed()
        crossings = np.bincount(p.region.edge_point, minlength=len(p.rows))
        for k, row in enumerate(p.rows.tolist()):
            out[row].update(feasible_mask=base64.b64encode(packed[k].tobytes()).decode("ascii"),
                            feasible_crossings=int(crossings[k]))
    return out


def _feasible_grid(program: Program, o: int, rotary: RotaryMotion) -> FeasibleGrid | None:
    """The grid and the planner of multi-axis operation o re-oriented by the allowable planner
    (None otherwise)."""
    p = reoriented_fives(program).get(o)
    if p is None or p.region is None:
        return None
    motion, cam_motion = rotary.five_axis[o]
    return FeasibleGrid(
        leads=np.degrees(p.region.leads).round(9).tolist(),
        tilts=np.degrees(p.region.tilts).round(9).tolist(),
        boundary_tolerance=float(np.degrees(p.region.tolerance)),
        method=f"{p.planned.method}, then {p.chosen.method}", points=len(p.rows),
        infeasible_points=int((~p.chosen.feasible).sum()),
        cam_infeasible_points=int((~p.cam_feasible).sum()),
        rotary_motion=motion, rotary_motion_cam=cam_motion)


def _contact_order(program: Program, o: int, rotary: RotaryMotion,
                   scallop: float) -> ContactOrder | None:
    """The poses, widths (at `scallop` mm) and planner of multi-axis operation o re-oriented by
    the contact-order planner (None otherwise)."""
    p = reoriented_fives(program).get(o)
    if p is None or p.contact is None:
        return None
    c = p.contact
    motion, cam_motion = rotary.five_axis[o]
    width = c.width[np.isfinite(c.width)]
    return ContactOrder(
        method=f"{p.planned.method}, then {p.chosen.method}", points=len(p.rows),
        infeasible_points=int((~p.chosen.feasible).sum()),
        cam_infeasible_points=int((~p.cam_feasible).sum()),
        raised_points=int((np.nan_to_num(c.raised) > 0).sum()),
        order=np.bincount(c.order, minlength=4).tolist(), scallop=scallop,
        width_min=_opt(width.min()) if width.size else None,
        width_median=_opt(np.median(width)) if width.size else None,
        ball_width_max=_opt(np.max(c.ball)), rotary_motion=motion, rotary_motion_cam=cam_motion)


def build_document(job: JobContext, program: Program, advice: Advice, rotary: RotaryMotion,
                   t0: float) -> ResultsDocument:
    """The results document (see the module docstring) of the check begun at `t0`
    (`time.perf_counter`, s)."""
    m = job.m
    w = program.written
    pose_verdict, clearance = advice.pose_verdict, advice.holder_clearance
    at_rows = pose_of_rows(w.moves, np.arange(len(m)))
    cam_row_verdict = cam_row_depth = None
    if program.cam is not None:
        cam_at = pose_of_rows(program.cam.moves, np.arange(len(m)))
        cam_row_verdict = program.cam.pose_verdict[cam_at]
        cam_row_depth = program.cam.poses.depth[cam_at]
    five = _five_points(program)
    points: list[PointResult] = []
    for i in range(len(w.moves)):
        row = int(w.moves.row[i])
        first_of_row = at_rows[row] == i
        extra = {}
        if first_of_row and advice.given(row):
            extra = dict(
                cc=_vec(advice.cc[row]), normal=_vec(advice.normal[row]),
                cc_surface=None if advice.cc_surface[row] < 0 else int(advice.cc_surface[row]),
                allowable=_opt(advice.size[row]), limiting_point=_vec(advice.limiting[row]),
                limiting_surface=None if advice.limiting_surface[row] < 0 else
                int(advice.limiting_surface[row]),
                margin=_opt(advice.margin[row]), b_original=_opt(advice.b_original[row]),
                b_best=_opt(advice.b_best[row]), allowable_at_best=_opt(advice.at_best[row]),
                b_feasible=advice.feasible[row])
        if first_of_row and cam_row_verdict is not None and \
                program.handling[int(m.op[row])] != "as-programmed":
            extra.update(verdict_cam=str(cam_row_verdict[row]),
                         depth_cam=_opt(cam_row_depth[row]))
        if np.isfinite(clearance[i]):
            extra["holder_clearance"] = float(clearance[i])
        if first_of_row and row in five:
            extra.update(five[row])
        points.append(_point(job, program, w, i, row, pose_verdict[i],
                             "cycle" if w.moves.hole[i] else "cl", **extra))
    along = w.along
    pen = np.flatnonzero(along.depths.depth > 0.0)
    for k in pen:
        i = int(along.end[k])
        row = int(w.moves.row[i])
        points.append(PointResult(
            index=len(points), kind="move", move=row, line=int(m.line[row]), op=int(m.op[row]),
            rapid=bool(w.moves.kind[i] == RAPID), tip=_vec(along.tip[k]), axis=_vec(along.axis[k]),
            t=float(along.t[k]), b=_opt(program.b[row]), verdict=str(w.move_verdict[k]),
            depth=float(along.depths.depth[k]), tolerance=float(w.move_tolerance[k]),
            piece=_PIECES[int(along.depths.piece[k])] if along.depths.piece[k] >= 0 else None,
            point=_vec(along.depths.point[k]), surface=_surface(job, along.depths.triangle[k])))
    summary = _summary(job, program, points, advice, t0)
    stock = None if program.stock is None else program.stock.result
    if stock is not None:
        _with_stock(summary, stock)
    cutters = job.cutters
    first = cutters[int(m.op[np.flatnonzero(~m.rapid)[0]])]
    info = JobInfo(
        path=str(job.apt_path), dialect=job.toolpath.dialect, units=job.toolpath.units,
        part=str(job.part_path), part_hash=job.part.content_hash,
        part_transform=job.part_transform, cutter=first.to_apt(), cutter_kind=first.kind,
        cutter_size=float(first.size), cutters=[cutters[o].to_apt() for o in sorted(cutters)],
        machine=None if job.machine is None else job.machine.name,
        axis_class=_job_class(job.classes))
    return ResultsDocument(job=info, summary=summary,
                           operations=_operations(job, program, rotary),
                           orientation=_orientation(rotary), points=points, stock=stock)


def _orientation(rotary: RotaryMotion) -> Orientation | None:
    """The 4-axis rotary motion of the written program and of the CAM's, the greedy
    smoothing's and the points with no feasible B (None when no operation was planned)."""
    r = rotary.four_axis
    if r is None:
        return None
    return Orientation(dp_total_rotation=r.written, greedy_total_rotation=r.greedy,
                       original_total_rotation=r.cam, infeasible_points=r.infeasible_points)


def stock_document(job: JobContext, motion: ProgramMotion, checked: StockCheck,
                   t0: float) -> ResultsDocument:
    """The results document of a check against the stock and the fixtures alone (no part):
    no points, the stock's verdicts as the counts (`checked`, per pose of `motion`), begun at
    `t0` (`time.perf_counter`, s)."""
    m, stock = job.m, checked.result
    cutters, classes, tol, mach = job.cutters, job.classes, job.tolerance, job.machine
    first = cutters[int(m.op[0])]
    summary = Summary(
        status="findings" if stock.findings else "ok", points=0, cl_points=0, move_points=0,
        poses_checked=len(motion.moves), counts=counts(list(checked.verdict)),
        tolerance=float(tol.value.max()), part_deviation=0.0, worst_margin=None,
        worst_depth=max((f.depth for f in stock.findings), default=None),
        largest_safe_cutter=None, largest_safe_standard_cutter=None, worst=[],
        time_s=time.perf_counter() - t0)
    _with_stock(summary, stock)
    summary.counts = counts(list(checked.verdict))
    info = JobInfo(path=str(job.apt_path), dialect=job.toolpath.dialect,
                   units=job.toolpath.units, cutter=first.to_apt(), cutter_kind=first.kind,
                   cutter_size=float(first.size),
                   cutters=[cutters[o].to_apt() for o in sorted(cutters)],
                   machine=None if mach is None else mach.name, axis_class=_job_class(classes))
    ops = [OperationResult(
        index=o, name=job.toolpath.operations[o].name, cutter=cutters[o].to_apt(),
        axis_class=classes[o], handling="as-programmed", tolerance=float(tol.value[o]),
        tolerance_source=tol.source[o], counts=counts(list(checked.verdict[motion.op_of == o])))
        for o in sorted(classes)]
    return ResultsDocument(job=info, summary=summary, operations=ops, points=[], stock=stock)


def _with_stock(summary: Summary, stock) -> None:
    """The findings against the stock and the fixtures in the summary: its counts, status and
    worst findings."""
    for f in stock.findings:
        setattr(summary.counts, f.verdict, getattr(summary.counts, f.verdict) + 1)
    if stock.findings or (stock.machined is not None and stock.machined.gouge_points):
        summary.status = "findings"  # the as-cut gouges: counted in stock.machined only
    extra = [Finding(index=f.index, kind="stock" if f.against == "stock" else "fixture",
                     verdict=f.verdict, line=f.line, op=f.op, tip=f.tip, point=f.point,
                     depth=f.depth) for f in stock.findings]
    summary.worst = sorted(summary.worst + extra, key=lambda f: -(f.depth or 0.0))[:_WORST]


def _surface(job: JobContext, triangle: int) -> int | None:
    if triangle < 0 or job.triangles.surface[triangle] < 0:
        return None
    return int(job.triangles.surface[triangle])


def _point(job: JobContext, program: Program, w: Verified, i: int, row: int, verdict: str,
           kind: str, **extra) -> PointResult:
    m = job.m
    piece = int(w.poses.piece[i])
    return PointResult(
        index=i, kind=kind, move=row, line=int(m.line[row]), op=int(m.op[row]),
        rapid=bool(w.moves.kind[i] == RAPID or m.rapid[row]), tip=_vec(w.moves.tip[i]),
        axis=_vec(w.moves.axis[i]), b=_opt(program.b[row]), verdict=str(verdict),
        depth=_opt(w.poses.depth[i]), piece=_PIECES[piece] if piece >= 0 else None,
        tolerance=float(w.tolerance[i]),
        point=_vec(w.poses.point[i]), surface=_surface(job, w.poses.triangle[i]), **extra)


def _job_class(classes: dict) -> str:
    kinds = set(classes.values())
    if kinds <= {"3-axis"}:
        return "3-axis"
    if "multi-axis" in kinds:
        return "multi-axis"
    return "4-axis-Y"


def _op_counts(v: Verified, o: int, job: JobContext) -> VerdictCounts:
    mine = job.m.op[v.moves.row] == o
    at = np.isin(v.along.end, np.flatnonzero(mine))
    return counts(list(v.pose_verdict[mine]) + list(v.move_verdict[at]))


def _operations(job: JobContext, program: Program,
                rotary: RotaryMotion) -> list[OperationResult]:
    cutters, classes, tol = job.cutters, job.classes, job.tolerance
    out = []
    for o in sorted(classes):
        rows = np.flatnonzero(job.m.op == o)
        b = program.b[rows]
        op = job.toolpath.operations[o]
        out.append(OperationResult(
            index=o, name=op.name, cutter=cutters[o].to_apt(), axis_class=classes[o],
            handling=program.handling[o],
            b_written=[float(np.nanmin(b)), float(np.nanmax(b))] if np.isfinite(b).any() else
            None,
            tolerance=float(tol.value[o]), tolerance_source=tol.source[o],
            counts=_op_counts(program.written, o, job),
            counts_cam=None if program.cam is None else _op_counts(program.cam, o, job),
            feasible_grid=_feasible_grid(program, o, rotary),
            contact_order=_contact_order(program, o, rotary, job.cfg.five_axis.scallop_height)))
    return out


def _summary(job: JobContext, program: Program, points: list[PointResult], advice: Advice,
             t0: float) -> Summary:
    w = program.written
    verdicts = [p.verdict for p in points]
    all_counts = counts([p.verdict for p in points if p.kind != "move"] + list(w.move_verdict))
    cam_counts = None
    if program.cam is not None:
        c = program.cam
        cam_counts = counts(list(c.pose_verdict) + list(c.move_verdict))
    bad = [p for p in points if p.verdict in vd.FINDINGS]
    bad.sort(key=lambda p: -(p.depth or 0.0))
    worst = [Finding(index=p.index, kind=p.kind, verdict=p.verdict, line=p.line, op=p.op,
                     tip=p.tip, point=p.point, depth=p.depth, b=p.b, margin=p.margin)
             for p in bad[:_WORST]]
    depths = [p.depth for p in points if p.depth is not None]
    return Summary(
        status=vd.status(verdicts), points=len(points),
        cl_points=sum(p.kind != "move" for p in points),
        move_points=len(w.along.end), poses_checked=len(w.moves) + int(w.along.poses.sum()),
        counts=all_counts, counts_cam=cam_counts, tolerance=float(job.tolerance.value.max()),
        part_deviation=float(job.triangles.typical), worst_margin=advice.worst_margin,
        worst_depth=float(max(depths)) if depths else None,
        largest_safe_cutter=advice.largest_safe,
        largest_safe_standard_cutter=advice.largest_standard,
        worst=worst, time_s=time.perf_counter() - t0)


def stated_stock_text(toolpath: ToolPath, part_box: np.ndarray | None) -> str | None:
    """The stock the CL file states, placed against `part_box (2, 3)` mm (or the origin without
    a part) as `--stock cl` places it: one sentence (`checker.stock.stated.place`), or None."""
    from checker.stock.stated import place, stated_stock

    stated = stated_stock(toolpath)
    return None if stated is None else place(stated, part_box)[1]
