"""`check_job`: the main job shared by the CLI, the service and batch runs. Read the CL file, find
the contact point of every cutting pose on the part, the allowable cutter there, the verdict for
the real cutter, its margin and penetration depth; for 4-axis jobs the best and chosen table
angle B; the intermediate poses; summarise, and post the corrected G-code. Part frame, mm."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.config import Config, default_config, load_config
from checker.errors import PathcheckError
from checker.results import (
    Finding,
    JobInfo,
    Orientation,
    PointResult,
    ResultsDocument,
    Summary,
    VerdictCounts,
)

_WORST = 10
_FINDINGS = ("gouge", "interference", "holder")


def _config(config) -> Config:
    if config is None:
        return default_config()
    return config if isinstance(config, Config) else load_config(config)


def _part_path(apt_path: Path, part_path) -> Path:
    from checker.geometry import BESIDE_SUFFIXES, find_part_beside

    if part_path is not None:
        return Path(part_path)
    found = find_part_beside(apt_path)
    if found is None:
        raise PathcheckError(
            f"no part given and none beside the job: expected --part PATH or a file "
            f"{apt_path.stem}{{{','.join(BESIDE_SUFFIXES)}}}", path=apt_path, code="part")
    return found


def _cutters(toolpath, ops: np.ndarray, cutter, apt_path: Path) -> dict[int, object]:
    """The real cutter per operation index used by the cutting moves."""
    from checker.cutter import Cutter, parse_cutter

    if cutter is not None:
        c = cutter if isinstance(cutter, Cutter) else parse_cutter(str(cutter))
        return {int(o): c for o in np.unique(ops)}
    out = {}
    for o in np.unique(ops):
        op = toolpath.operations[int(o)]
        if op.cutter is None:
            rec = toolpath.records[op.first_record] if op.end_record > op.first_record else None
            raise PathcheckError(
                f"operation '{op.name}' has no cutter: expected a CUTTER/ or TLDATA/ statement "
                f"before its moves, or --cutter", path=apt_path,
                line=None if rec is None else rec.line, code="cutter")
        out[int(o)] = op.cutter
    return out


def _depth(cutter, tips: np.ndarray, axes: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(N,) penetration (mm, >= 0) of the real cutter at its CL poses into points (part frame),
    each row in its own tool frame."""
    from checker.engine.frames import rotate_rows, tool_rotations

    out = np.zeros(len(tips))
    rows = np.flatnonzero(np.isfinite(pts).all(axis=1))
    if rows.size:
        local = rotate_rows(tool_rotations(axes[rows]), pts[rows] - tips[rows])
        out[rows] = np.maximum(-cutter.signed_distance(local), 0.0)
    return out


@dataclass
class _Rows:
    """Per cutting row (N,) of the job, filled one cutter at a time."""

    n: int

    def __post_init__(self) -> None:
        n = self.n
        self.cc, self.nrm = np.zeros((n, 3)), np.zeros((n, 3))
        self.sid, self.gap = np.full(n, -1), np.zeros(n)
        self.size, self.lim, self.lsid = np.zeros(n), np.full((n, 3), np.nan), np.full(n, -1)
        self.verdict = np.full(n, "ok", dtype=object)
        self.margin, self.depth = np.zeros(n), np.zeros(n)
        self.b_original = np.full(n, np.nan)
        self.b_best = np.full(n, np.nan)
        self.at_best = np.full(n, np.nan)
        self.feasible: list = [None] * n
        self.b_chosen = np.full(n, np.nan)
        self.verdict_chosen = np.full(n, None, dtype=object)
        self.margin_chosen = np.full(n, np.nan)
        self.tips_chosen = np.zeros((n, 3))
        self.holder = np.full(n, np.nan)


def check_job(apt_path, part_path=None, cutter=None, machine=None, config=None,
              output=None, *, b_range: tuple[float, float] | None = None,
              reorient: bool = False) -> ResultsDocument:
    """Check a job: `apt_path` the CL file; `part_path` the part (default: the file beside the
    job with the same stem); `cutter` a `Cutter` or "CUTTER/..." overriding the file's; `config`
    a Config or a TOML path; `machine` a machine name or TOML file (default: the CL file's
    `PPRINT/MACHINE`, else fanuc-hmc); `output` the corrected G-code to write; `b_range`
    (degrees) the B range searched for 4-axis jobs; `reorient` plans B for a 3-axis path too.

    Every cutting pose gets its contact point, the allowable size, the verdict for the real
    cutter, the margin and the penetration depth; 4-axis jobs get the best B, the feasible B
    intervals and the chosen B (verdicts there too); the intermediate poses between cutting
    blocks are checked, and the shank and holder where the cutter carries them."""
    from checker.apt import read_cl

    t0 = time.perf_counter()
    toolpath = read_cl(Path(apt_path), require_cutter=cutter is None)
    return check_toolpath(toolpath, part_path=part_path, cutter=cutter, machine=machine,
                          config=config, output=output, b_range=b_range, reorient=reorient,
                          started=t0)


def check_toolpath(toolpath, part_path=None, cutter=None, machine=None, config=None,
                   output=None, *, b_range: tuple[float, float] | None = None,
                   reorient: bool = False, started: float | None = None) -> ResultsDocument:
    """`check_job` on a tool path already in memory (read from a CL file, or from a G-code
    program by `pathcheck check-gcode`); `toolpath.path` names the job."""
    from checker.apt.info import axis_class
    from checker.geometry import load_part
    from checker.geometry.sampling import sample_part

    t0 = time.perf_counter() if started is None else started
    cfg = _config(config)
    apt_path = Path(toolpath.path)
    m = toolpath.motion_arrays(arc_chord_tol=cfg.check.arc_chord_tolerance)
    cut = np.flatnonzero(~np.asarray(m.rapid, bool))
    if cut.size == 0:
        raise PathcheckError("no cutting moves: expected GOTO records after FEDRAT, found only "
                             "rapid moves or none", path=apt_path, code="parse")
    tips, axes, ops = m.tip[cut], m.axis[cut], m.op[cut]
    cls = axis_class(axes, cfg.four_axis.axis_j_tolerance)
    four_axis = cls == "4-axis-Y" or reorient or b_range is not None
    mach = None
    if four_axis or output is not None:
        from postproc.post import machine_for_toolpath

        mach = machine_for_toolpath(toolpath, None if machine is None else str(machine))
    ppath = _part_path(apt_path, part_path)
    part = load_part(ppath)
    samples = sample_part(part, geometry=cfg.geometry)
    cutters = _cutters(toolpath, ops, cutter, apt_path)
    rows_out = _Rows(len(cut))
    pose_points: list[tuple] = []
    orientation = None
    for o, c in cutters.items():
        rows = np.flatnonzero(ops == o)
        path_checks = _check_cutter(toolpath, m, cut, rows, c, part, samples, rows_out, cfg,
                                    four_axis, b_range, mach, apt_path)
        if path_checks.poses is not None and len(path_checks.poses.depth):
            pose_points.append((rows, path_checks))
        if path_checks.orientations is not None:
            orientation = _merge_orientation(orientation, path_checks.orientations)
    first = cutters[int(ops[0])]
    points = _cc_points(rows_out, cut, m, tips, axes, four_axis)
    points += _pose_points(pose_points, cut, m, len(points), four_axis)
    summary = _summary(points, rows_out, first, four_axis, time.perf_counter() - t0)
    job = JobInfo(
        path=str(apt_path), dialect=toolpath.dialect, units=toolpath.units, part=str(ppath),
        part_hash=part.content_hash, cutter=first.to_apt(), cutter_kind=first.kind,
        cutter_size=float(first.size), machine=None if mach is None else mach.name,
        axis_class=cls,
    )
    doc = ResultsDocument(job=job, summary=summary, orientation=orientation, points=points)
    if output is not None:
        doc.gcode = str(_post(toolpath, m, cut, rows_out, four_axis, cls, output, mach, cfg,
                              apt_path))
    doc.summary.time_s = time.perf_counter() - t0
    return doc


def _check_cutter(toolpath, m, cut, rows, c, part, samples, out: _Rows, cfg, four_axis, b_range,
                  mach, apt_path):
    """Contacts, allowable sizes and verdicts of one cutter's rows, then the path checks."""
    from checker.engine import allowable
    from checker.four_axis.job import check_path, segments_of
    from checker.geometry.contact import cl_to_cc, contact_from_toolpath

    tips, axes = m.tip[cut[rows]], m.axis[cut[rows]]
    given = contact_from_toolpath(toolpath, m.line[cut[rows]])
    con = cl_to_cc(part, samples, c, tips, axes, contact=given)
    res = allowable(samples, part, c, con.cc, con.normal, axes, cc_surface=con.surface,
                    cc_uv=con.uv, toward=tips - con.cc, config=cfg)
    out.cc[rows], out.nrm[rows], out.sid[rows], out.gap[rows] = (con.cc, con.normal,
                                                                 con.surface, con.gap)
    out.size[rows], out.lim[rows], out.lsid[rows] = (res.size, res.limiting_point,
                                                     res.limiting_surface)
    out.margin[rows] = res.margin
    d = _depth(c, tips, axes, res.limiting_point)
    out.depth[rows] = np.maximum(d, np.maximum(-con.gap, 0.0))
    v = res.verdict.astype(object)
    cuts_in = con.gap < -cfg.check.depth_tolerance  # the real cutter penetrates here
    v[cuts_in & (v != "interference")] = "gouge"
    center, limits = np.zeros(3), (-360.0, 360.0)
    if mach is not None:
        center = np.asarray(mach.kinematics.table_center, dtype=float)
        if mach.rotary.wrap == "limited":
            limits = (mach.rotary.b_min, mach.rotary.b_max)
    pc = check_path(test_points=samples, part=part, cutter=c, contacts=con, tips=tips, axes=axes,
                    lines=m.line[cut[rows]], segments=segments_of(cut[rows], m.op[cut[rows]]),
                    four_axis=four_axis, b_range=b_range, machine_limits=limits,
                    table_center=center, path=str(apt_path), cfg=cfg)
    held = np.isfinite(pc.holder_clearance)
    v[held & (v == "ok")] = "holder"
    out.verdict[rows] = v
    out.holder[rows] = pc.holder_clearance
    out.tips_chosen[rows] = pc.tips_chosen
    if pc.orientations is not None:
        o = pc.orientations
        out.b_original[rows], out.b_best[rows] = o.original, o.best.b_best
        out.at_best[rows], out.b_chosen[rows] = o.best.allowable_at_best, pc.b_chosen
        for k, r in enumerate(rows):
            out.feasible[r] = o.best.feasible[k]
        out.verdict_chosen[rows], out.margin_chosen[rows] = pc.verdict_chosen, pc.margin_chosen
    return pc


def _merge_orientation(prev, o) -> Orientation:
    """Orientation totals of the job (summed over its cutters)."""
    infeasible = int((~o.chosen.feasible).sum())
    now = Orientation(dp_total_rotation=o.chosen.total_rotation,
                      greedy_total_rotation=o.greedy.total_rotation,
                      original_total_rotation=o.original_rotation, infeasible_points=infeasible)
    if prev is None:
        return now
    return Orientation(**{k: getattr(prev, k) + getattr(now, k) for k in Orientation.model_fields})


def _opt(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _vec(v: np.ndarray):
    return tuple(float(x) for x in v) if np.isfinite(v).all() else None


def _cc_points(r: _Rows, cut, m, tips, axes, four_axis: bool) -> list[PointResult]:
    out = []
    for i in range(r.n):
        extra = {}
        if four_axis:
            extra = dict(
                b_original=_opt(r.b_original[i]), b_best=_opt(r.b_best[i]),
                allowable_at_best=_opt(r.at_best[i]), b_feasible=r.feasible[i],
                b_chosen=_opt(r.b_chosen[i]),
                verdict_chosen=None if r.verdict_chosen[i] is None else str(r.verdict_chosen[i]),
                margin_chosen=_opt(r.margin_chosen[i]),
            )
        out.append(PointResult(
            index=i, kind="cc", move=int(cut[i]), line=int(m.line[cut[i]]),
            cc=_vec(r.cc[i]), normal=_vec(r.nrm[i]), tip=_vec(tips[i]), axis=_vec(axes[i]),
            surface=None if r.sid[i] < 0 else int(r.sid[i]),
            allowable=_opt(r.size[i]), limiting_point=_vec(r.lim[i]),
            limiting_surface=None if r.lsid[i] < 0 else int(r.lsid[i]),
            verdict=str(r.verdict[i]), margin=_opt(r.margin[i]), depth=float(r.depth[i]),
            holder_clearance=_opt(r.holder[i]), **extra,
        ))
    return out


def _pose_points(groups, cut, m, start: int, four_axis: bool) -> list[PointResult]:
    """Intermediate poses as points, after the CC points."""
    out = []
    for rows, pc in groups:
        pk = pc.poses
        con = pk.contacts
        for j in range(len(pk.depth)):
            row = rows[pk.poses.move[j]]
            out.append(PointResult(
                index=start + len(out), kind="intermediate", move=int(cut[row]),
                line=int(m.line[cut[row]]), cc=_vec(con.cc[j]), normal=_vec(con.normal[j]),
                tip=_vec(pk.poses.tip[j]), axis=_vec(pk.poses.axis[j]),
                surface=None if con.surface[j] < 0 else int(con.surface[j]),
                allowable=_opt(pk.size[j]), limiting_point=_vec(pk.limiting_point[j]),
                limiting_surface=None if pk.limiting_surface[j] < 0 else
                int(pk.limiting_surface[j]),
                verdict=str(pk.verdict[j]), margin=_opt(pk.margin[j]),
                depth=float(pk.depth[j]),
                b_chosen=float(pk.poses.b[j]) if four_axis else None,
                holder_clearance=_opt(pc.pose_holder_clearance[j]),
            ))
    return out


def _post(toolpath, m, cut, r: _Rows, four_axis: bool, cls: str, output, mach, cfg, apt_path):
    """Write the corrected G-code: every motion row with the B chosen at its cutting row (rapids
    and approach moves follow the nearest cutting row, moved with it), flags as comments."""
    from postproc.post import post_toolpath

    if cls == "multi-axis" and not four_axis:
        raise PathcheckError("cannot post a multi-axis path for a 4-axis machine: expected tool "
                             "axes perpendicular to Y (j = 0)", path=apt_path, code="not-4-axis")
    n_rows = len(m.tip)
    nearest = np.clip(np.searchsorted(cut, np.arange(n_rows)), 0, len(cut) - 1)
    prev = np.clip(nearest - 1, 0, len(cut) - 1)
    same_op = m.op[cut[nearest]] == m.op
    k = np.where(same_op | (m.op[cut[prev]] != m.op), nearest, prev)
    if four_axis:
        from checker.four_axis.axes import b_for_axis, rotate_about_y

        b_new = r.b_chosen[k]
        b_old = b_for_axis(m.axis[cut[k]])
        tip = r.tips_chosen[k] + rotate_about_y(m.tip - m.tip[cut[k]], b_old - b_new, np.zeros(3))
        tip[cut] = r.tips_chosen
    else:
        b_new = np.zeros(n_rows) if cls == "3-axis" else None
        tip = None
    verdict = r.verdict_chosen if four_axis else r.verdict
    comments = [""] * n_rows
    for i, row in enumerate(cut):
        if verdict[i] not in (None, "ok"):
            margin = r.margin_chosen[i] if four_axis else r.margin[i]
            comments[row] = (f"PATHCHECK {str(verdict[i]).upper()} CL LINE {int(m.line[row])}"
                             f" MARGIN {margin:.4f}" if np.isfinite(margin) else
                             f"PATHCHECK {str(verdict[i]).upper()} CL LINE {int(m.line[row])}")
    return post_toolpath(toolpath, output, machine=None if mach is None else mach.name,
                         b_deg=b_new, comments=comments,
                         arc_chord_tol=cfg.check.arc_chord_tolerance, tip=tip)


def _counts(verdicts) -> VerdictCounts:
    v = np.asarray(list(verdicts), dtype=object)
    return VerdictCounts(**{k: int((v == k).sum()) for k in VerdictCounts.model_fields})


def _summary(points: list[PointResult], r: _Rows, cutter, four_axis: bool,
             elapsed: float) -> Summary:
    """Counts by verdict (4-axis: CC points at the CAM's B in `counts`; at the chosen B, with the
    intermediate poses along the corrected path, in `counts_chosen`), worst findings, largest
    safe cutter."""
    poses = [p for p in points if p.kind == "intermediate"]
    cc_v = [str(v) for v in r.verdict]
    if four_axis:
        counts = _counts(cc_v)
        chosen = [str(v) for v in r.verdict_chosen] + [p.verdict for p in poses]
        counts_chosen = _counts(chosen)
    else:
        counts = _counts(cc_v + [p.verdict for p in poses])
        counts_chosen = None
    bad = [p for p in points if p.verdict in _FINDINGS]
    bad.sort(key=lambda p: (-(p.depth or 0.0), p.margin if p.margin is not None else 1e300))
    worst = [Finding(index=p.index, kind=p.kind, verdict=p.verdict, line=p.line, cc=p.cc,
                     depth=p.depth, margin=p.margin) for p in bad[:_WORST]]
    reach = np.isfinite(r.size) & (r.verdict != "inaccessible")
    smallest = float(r.size[reach].min()) if reach.any() else None
    depths = [p.depth for p in points if p.depth is not None]
    return Summary(
        points=len(points), cc_points=r.n, intermediate_points=len(poses), counts=counts,
        counts_chosen=counts_chosen,
        worst_margin=float(r.margin[reach].min()) if reach.any() else None,
        worst_depth=float(max(depths)) if depths else None,
        largest_safe_cutter=smallest,
        largest_safe_standard_cutter=_standard(cutter, smallest),
        worst=worst, time_s=elapsed,
    )


def _standard(cutter, size: float | None) -> str | None:
    """Name of the largest tool-library cutter of the real cutter's family not above `size`."""
    if size is None:
        return None
    from checker.tool_library import load_tool_library

    r = None if cutter.kind in ("ball", "tapered_ball") else cutter.r
    best = load_tool_library().largest_not_exceeding(cutter.kind, size, r, theta=cutter.theta)
    return None if best is None else best.name
