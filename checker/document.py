"""The results document of a checked job, built from the program that is written
(`checker.written.Program`): a point per pose at a CL record or a canned-cycle hole, a point per
move that penetrates somewhere along its length (at its deepest pose), the advice at the
cutting poses (contact, allowable cutter, margin; 4-axis: best B and feasible B; re-oriented
multi-axis: the axis's lead and tilt and, by the allowable planner, the feasible set as bits of
the operation's grid), per operation what was done with it (and how a multi-axis one was
planned), and the summary whose status is the one answer. mm, degrees, part frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from checker import verdict as vd
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
from checker.tool_library import largest_standard

_WORST = 10
_MESH_SIZE_CAP = 4.0  # mesh parts: allowable sizes are searched up to this many real sizes
_MESH_SIZE_TOL = 1e-4  # mm: and bisected to this
_TOUCH = 0.05  # mm: cutting poses this near the part touch it (advice is given for them)
_PIECES = ("body", "shank", "holder")


def _opt(x) -> float | None:
    return float(x) if x is not None and np.isfinite(x) else None


def _vec(v) -> tuple[float, float, float] | None:
    return tuple(float(x) for x in v) if v is not None and np.isfinite(v).all() else None


def counts(verdicts) -> VerdictCounts:
    """Counts by verdict."""
    v = np.asarray(list(verdicts), dtype=object)
    return VerdictCounts(**{k: int((v == k).sum()) for k in VerdictCounts.model_fields})


class _Advice:
    """Per motion row: contact, allowable size, limiting point and margin, and the 4-axis
    best-B advice, for the cutting rows (nan / None elsewhere)."""

    def __init__(self, n: int) -> None:
        self.cc = np.full((n, 3), np.nan)
        self.normal = np.full((n, 3), np.nan)
        self.cc_surface = np.full(n, -1, dtype=np.int64)
        self.size = np.full(n, np.nan)
        self.limiting = np.full((n, 3), np.nan)
        self.limiting_surface = np.full(n, -1, dtype=np.int64)
        self.margin = np.full(n, np.nan)
        self.inaccessible = np.zeros(n, dtype=bool)
        self.b_original = np.full(n, np.nan)
        self.b_best = np.full(n, np.nan)
        self.at_best = np.full(n, np.nan)
        self.feasible: list = [None] * n


def _advice(job, program, cutters: dict) -> _Advice:
    """The allowable cutter at the written cutting poses that touch the part (within twice
    their tolerance or _TOUCH): NURBS parts through the engine at the contact (CL -> CC), mesh
    parts by the exact triangle tests (`mesh.allowable_on_mesh`, up
    to _MESH_SIZE_CAP times the real size: larger is reported as unbounded), contact at the
    nearest point."""
    from checker.written import cutting_rows

    m = job.m
    out = _Advice(len(m))
    w = program.written
    at = _pose_of_rows(w.moves, np.arange(len(m)))
    touching = w.poses.depth[at] > -np.maximum(2.0 * w.tolerance[at], _TOUCH)
    for o, c in cutters.items():
        rows = cutting_rows(job, np.flatnonzero((m.op == o) & touching))
        if rows.size == 0:
            continue
        tips, axes = program.tip[rows], program.axis[rows]
        if job.part.surfaces:
            _engine_advice(job, program, o, c, rows, tips, axes, out)
        else:
            _mesh_advice(job, program, c, rows, tips, axes, out)
        _clean_is_safe(out, rows, w.pose_verdict[at[rows]], float(c.size))
    return out


def _clean_is_safe(out: _Advice, rows: np.ndarray, verdicts: np.ndarray, real: float) -> None:
    """The advice never calls the real cutter (size `real` mm) unsafe at a pose where the check
    finds it clean: at the `rows` whose pose's verdict (`verdicts`) is no finding, an allowable
    size below the real one (and its margin) is raised to it. The check measures the real tool
    at the pose against the part with the job's tolerance, and its verdict is the one answer;
    the engine's size is that of a cutter tangent at the contact with no depth tolerance, which
    a crease of a fraction of a degree (a B-spline's knot line) brings below any real size.
    Contacts that cannot be touched (`inaccessible`) keep their mark."""
    clean = rows[~vd.is_finding(verdicts) & np.isfinite(out.size[rows])
                 & ~out.inaccessible[rows]]
    out.size[clean] = np.maximum(out.size[clean], real)
    out.margin[clean] = out.size[clean] - real


def _engine_advice(job, program, o, c, rows, tips, axes, out: _Advice) -> None:
    from checker.engine import allowable
    from checker.geometry.contact import cl_to_cc, contact_from_toolpath

    plan = program.plans.get(o)
    samples = job.test_points()
    hint = None
    if plan is not None and program.handling[o] == "re-oriented":
        # the contact the plan turned the tool about: the CAM's own (CL -> CC at its B)
        pick = np.searchsorted(plan.rows, rows)
        pc = plan.contacts
        con = type(pc)(pc.cc[pick], pc.normal[pick], pc.surface[pick], pc.uv[pick],
                       pc.gap[pick])
        hint = plan.orientations.best.allowable_at_best[pick]  # near the chosen B's: time only
    else:
        given = contact_from_toolpath(job.toolpath, job.m.line[rows])
        con = cl_to_cc(job.part, samples, c, tips, axes, contact=given)
    res = allowable(samples, job.part, c, con.cc, con.normal, axes, cc_surface=con.surface,
                    cc_uv=con.uv, toward=tips - con.cc, config=job.cfg, hint=hint)
    out.cc[rows], out.normal[rows], out.cc_surface[rows] = con.cc, con.normal, con.surface
    out.size[rows], out.limiting[rows] = res.size, res.limiting_point
    out.limiting_surface[rows], out.margin[rows] = res.limiting_surface, res.margin
    out.inaccessible[rows] = res.verdict == "inaccessible"
    if plan is not None:
        o_ = plan.orientations
        at = np.searchsorted(rows, plan.rows)
        ok = (at < len(rows)) & (rows[np.minimum(at, len(rows) - 1)] == plan.rows)
        r = plan.rows[ok]
        out.b_original[r], out.b_best[r] = o_.original[ok], o_.best.b_best[ok]
        out.at_best[r] = o_.best.allowable_at_best[ok]
        for k, row in zip(np.flatnonzero(ok), r, strict=True):
            out.feasible[row] = o_.best.feasible[k]


def _mesh_advice(job, program, c, rows, tips, axes, out: _Advice) -> None:
    from checker.mesh.allowable import allowable_on_mesh

    w = program.written
    at = _pose_of_rows(w.moves, rows)
    point = w.poses.point[at]
    tri = w.poses.triangle[at]
    touching = (tri >= 0) & np.isfinite(point).all(axis=1)
    nrm = np.full((len(rows), 3), np.nan)
    V, T = job.triangles.vertices, job.triangles.triangles
    t = tri[touching]
    n = np.cross(V[T[t, 1]] - V[T[t, 0]], V[T[t, 2]] - V[T[t, 0]])
    nrm[touching] = n / np.linalg.norm(n, axis=1)[:, None]
    facing = touching & (np.einsum("ij,ij->i", np.nan_to_num(nrm), axes) > 1e-9)
    out.cc[rows[touching]], out.normal[rows[touching]] = point[touching], nrm[touching]
    if facing.any():
        size = allowable_on_mesh(job.index, c, point[facing], nrm[facing], axes[facing],
                                 tol=float(w.tolerance[at][facing].max()),
                                 s_max=_MESH_SIZE_CAP * float(c.size), s_tol=_MESH_SIZE_TOL)
        r = rows[facing]
        out.size[r] = size
        out.margin[r] = size - float(c.size)
    out.inaccessible[rows[touching & ~facing]] = True


def _holder_clearance(job, w, cutters: dict, verdicts: np.ndarray) -> np.ndarray:
    """Per pose: at holder hits, the stick-out that clears the holder (mm; advice, from the
    part's triangle vertices), nan elsewhere."""
    from checker.four_axis.holder import check_holder
    from checker.four_axis.plan import holder_of

    out = np.full(len(verdicts), np.nan)
    hit = np.flatnonzero(verdicts == "holder")
    for o in np.unique(job.m.op[w.moves.row[hit]]):
        spec = holder_of(cutters[int(o)])
        if spec is None:
            continue
        mine = hit[job.m.op[w.moves.row[hit]] == o]
        got = check_holder(job.triangles.vertices, w.moves.tip[mine], w.moves.axis[mine], **spec)
        out[mine] = got.required_stickout
    return out


def _pose_of_rows(moves, rows: np.ndarray) -> np.ndarray:
    """The pose of each motion row (the first pose it makes)."""
    first = np.searchsorted(moves.row, rows)
    return np.minimum(first, len(moves.row) - 1)


def _orientation(job, program) -> Orientation | None:
    """The rotary motion (sum of |dB| along every motion row with a B, operation changes
    included) of the written program (`dp_total_rotation`) and of the CAM's
    (`original_total_rotation`); the greedy smoothing's inside the planned operations; the
    points with no feasible B. None when no operation was planned."""
    from checker.four_axis.orientation import total_rotation
    from checker.written import cam_b

    plans = [p for o, p in program.plans.items() if program.handling[o] != "as-programmed"]
    if not plans:
        return None
    b_cam = cam_b(job)
    return Orientation(
        dp_total_rotation=total_rotation(program.b[np.isfinite(program.b)]),
        greedy_total_rotation=sum(float(p.orientations.greedy.total_rotation) for p in plans),
        original_total_rotation=total_rotation(b_cam[np.isfinite(b_cam)]),
        infeasible_points=sum(int((~p.orientations.chosen.feasible).sum()) for p in plans))


def _reoriented(program) -> dict:
    """The multi-axis plans whose program is written (handling re-oriented)."""
    return {o: p for o, p in program.fives.items() if program.handling[o] == "re-oriented"}


def _five_points(program) -> dict[int, dict]:
    """Per contact row of a re-oriented multi-axis operation: the written axis's lead and tilt
    (degrees), its feasible grid nodes (base64 bits) and the count of boundary crossings."""
    import base64

    out: dict[int, dict] = {}
    for p in _reoriented(program).values():
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


def _rotary_motion(p, chain) -> tuple[float | None, float | None]:
    """Total motion of the machine's rotary words (degrees) along a multi-axis plan's contact
    points at its chosen axes and at the CAM's (None without a 5-axis chain)."""
    from checker.five_axis.plan import rotary_metrics

    if chain is None:
        return None, None
    return (rotary_metrics(chain, p, p.chosen.axis).total_motion_deg,
            rotary_metrics(chain, p, p.cam_axis).total_motion_deg)


def _feasible_grid(program, o: int, chain) -> FeasibleGrid | None:
    """The grid and the planner of multi-axis operation o re-oriented by the allowable planner
    (None otherwise)."""
    p = _reoriented(program).get(o)
    if p is None or p.region is None:
        return None
    motion, cam_motion = _rotary_motion(p, chain)
    return FeasibleGrid(
        leads=np.degrees(p.region.leads).round(9).tolist(),
        tilts=np.degrees(p.region.tilts).round(9).tolist(),
        boundary_tolerance=float(np.degrees(p.region.tolerance)),
        method=f"{p.planned.method}, then {p.chosen.method}", points=len(p.rows),
        infeasible_points=int((~p.chosen.feasible).sum()),
        cam_infeasible_points=int((~p.cam_feasible).sum()),
        rotary_motion=motion, rotary_motion_cam=cam_motion)


def _contact_order(program, o: int, chain, scallop: float) -> ContactOrder | None:
    """The poses, widths (at `scallop` mm) and planner of multi-axis operation o re-oriented by
    the contact-order planner (None otherwise)."""
    p = _reoriented(program).get(o)
    if p is None or p.contact is None:
        return None
    c = p.contact
    motion, cam_motion = _rotary_motion(p, chain)
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


def build_document(job, program, cutters: dict, classes: dict, tol, ppath: Path,
                   transform, mach, t0: float) -> ResultsDocument:
    """The results document (see the module docstring)."""
    import time

    m = job.m
    w = program.written
    advice = _advice(job, program, cutters)
    pose_verdict = w.pose_verdict.copy()
    at_rows = _pose_of_rows(w.moves, np.arange(len(m)))
    access = advice.inaccessible[w.moves.row] & (pose_verdict == "ok")
    pose_verdict[access & ~w.moves.hole] = "inaccessible"
    clearance = _holder_clearance(job, w, cutters, pose_verdict)
    cam_row_verdict = cam_row_depth = None
    if program.cam is not None:
        cam_at = _pose_of_rows(program.cam.moves, np.arange(len(m)))
        cam_row_verdict = program.cam.pose_verdict[cam_at]
        cam_row_depth = program.cam.poses.depth[cam_at]
    five = _five_points(program)
    points: list[PointResult] = []
    for i in range(len(w.moves)):
        row = int(w.moves.row[i])
        first_of_row = at_rows[row] == i
        extra = {}
        if first_of_row and np.isfinite(advice.size[row]) | np.isfinite(advice.cc[row]).all():
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
    summary = _summary(job, program, points, advice, cutters, tol, w, t0, time)
    stock = None if program.stock is None else program.stock.result
    if stock is not None:
        _with_stock(summary, stock)
    first = cutters[int(m.op[np.flatnonzero(~m.rapid)[0]])]
    info = JobInfo(
        path=str(job.apt_path), dialect=job.toolpath.dialect, units=job.toolpath.units,
        part=str(ppath), part_hash=job.part.content_hash, part_transform=transform,
        cutter=first.to_apt(), cutter_kind=first.kind, cutter_size=float(first.size),
        cutters=[cutters[o].to_apt() for o in sorted(cutters)],
        machine=None if mach is None else mach.name,
        axis_class=_job_class(classes))
    return ResultsDocument(job=info, summary=summary,
                           operations=_operations(job, program, cutters, classes, tol),
                           orientation=_orientation(job, program), points=points, stock=stock)


def stock_document(job, motion, checked, cutters: dict, classes: dict, tol, mach,
                   t0: float) -> ResultsDocument:
    """The results document of a check against the stock and the fixtures alone (no part):
    no points, the stock's verdicts as the counts (`checked`: `checker.stock.check.StockCheck`,
    per pose of `motion`)."""
    import time

    m, stock = job.m, checked.result
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


def _surface(job, triangle) -> int | None:
    if triangle < 0 or job.triangles.surface[triangle] < 0:
        return None
    return int(job.triangles.surface[triangle])


def _point(job, program, w, i, row, verdict, kind, **extra) -> PointResult:
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


def _op_counts(v: object, o: int, job) -> VerdictCounts:
    mine = job.m.op[v.moves.row] == o
    at = np.isin(v.along.end, np.flatnonzero(mine))
    return counts(list(v.pose_verdict[mine]) + list(v.move_verdict[at]))


def _operations(job, program, cutters, classes, tol) -> list[OperationResult]:
    motion = getattr(job, "motion", None)
    chain = None if motion is None else motion.chain
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
            feasible_grid=_feasible_grid(program, o, chain),
            contact_order=_contact_order(program, o, chain, job.cfg.five_axis.scallop_height)))
    return out


def _summary(job, program, points, advice, cutters, tol, w, t0, time) -> Summary:
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
    reach = np.isfinite(advice.size) & ~advice.inaccessible
    smallest = float(advice.size[reach].min()) if reach.any() else None
    depths = [p.depth for p in points if p.depth is not None]
    first = cutters[int(job.m.op[np.flatnonzero(~job.m.rapid)[0]])]
    return Summary(
        status=vd.status(verdicts), points=len(points),
        cl_points=sum(p.kind != "move" for p in points),
        move_points=len(w.along.end), poses_checked=len(w.moves) + int(w.along.poses.sum()),
        counts=all_counts, counts_cam=cam_counts, tolerance=float(tol.value.max()),
        part_deviation=float(job.triangles.typical),
        worst_margin=float(advice.margin[reach].min()) if reach.any() else None,
        worst_depth=float(max(depths)) if depths else None,
        largest_safe_cutter=smallest,
        largest_safe_standard_cutter=largest_standard(first, smallest),
        worst=worst, time_s=time.perf_counter() - t0)
