"""`check_job`: the main job shared by the CLI, the service and batch runs. Read the CL file, find
the contact point of every cutting pose on the part, the allowable cutter there, the verdict for
the real cutter, its margin and penetration depth, and summarise. Part frame, mm."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from checker.config import Config, default_config, load_config
from checker.errors import PathcheckError
from checker.results import (
    Finding,
    JobInfo,
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
    """(N,) penetration (mm, >= 0) of the real cutter at its CL poses into points (part frame)."""
    from checker.engine.frames import group_axes, tool_rotation

    out = np.zeros(len(tips))
    ok = np.isfinite(pts).all(axis=1)
    keys, group = group_axes(axes)
    for g, axis in enumerate(keys):
        rows = np.flatnonzero((group == g) & ok)
        if rows.size:
            Q = tool_rotation(axis)
            sd = cutter.signed_distance((pts[rows] - tips[rows]) @ Q.T)
            out[rows] = np.maximum(-sd, 0.0)
    return out


def check_job(apt_path, part_path=None, cutter=None, machine=None, config=None,
              output=None) -> ResultsDocument:
    """Check a job: `apt_path` the CL file; `part_path` the part (default: the file beside the
    job with the same stem); `cutter` a `Cutter` or "CUTTER/..." overriding the file's; `config`
    a Config or a TOML path. `machine` and `output` (G-code posting) belong to the 4-axis post
    and are not used by the 3-axis check. Every cutting pose gets its contact point, the
    allowable size, the verdict for the real cutter, the margin and the penetration depth."""
    from checker.apt import read_cl
    from checker.apt.info import axis_class
    from checker.engine import allowable
    from checker.geometry import load_part
    from checker.geometry.contact import cl_to_cc
    from checker.geometry.sampling import sample_part

    t0 = time.perf_counter()
    cfg = _config(config)
    apt_path = Path(apt_path)
    toolpath = read_cl(apt_path)
    m = toolpath.motion_arrays(arc_chord_tol=cfg.check.arc_chord_tolerance)
    cut = np.flatnonzero(~np.asarray(m.rapid, bool))
    if cut.size == 0:
        raise PathcheckError("no cutting moves: expected GOTO records after FEDRAT, found only "
                             "rapid moves or none", path=apt_path, code="parse")
    ppath = _part_path(apt_path, part_path)
    part = load_part(ppath)
    samples = sample_part(part, geometry=cfg.geometry)
    tips, axes, ops = m.tip[cut], m.axis[cut], m.op[cut]
    cutters = _cutters(toolpath, ops, cutter, apt_path)
    n = len(cut)
    cc, nrm = np.zeros((n, 3)), np.zeros((n, 3))
    sid, gap = np.full(n, -1), np.zeros(n)
    size, lim, lsid = np.zeros(n), np.full((n, 3), np.nan), np.full(n, -1)
    verdict, margin, depth = np.full(n, "ok", dtype=object), np.zeros(n), np.zeros(n)
    for o, c in cutters.items():
        rows = np.flatnonzero(ops == o)
        con = cl_to_cc(part, samples, c, tips[rows], axes[rows])
        res = allowable(samples, part, c, con.cc, con.normal, axes[rows], cc_surface=con.surface,
                        cc_uv=con.uv, toward=tips[rows] - con.cc, config=cfg)
        cc[rows], nrm[rows], sid[rows], gap[rows] = con.cc, con.normal, con.surface, con.gap
        size[rows], lim[rows], lsid[rows] = res.size, res.limiting_point, res.limiting_surface
        margin[rows] = res.margin
        d = _depth(c, tips[rows], axes[rows], res.limiting_point)
        depth[rows] = np.maximum(d, np.maximum(-con.gap, 0.0))
        v = res.verdict.astype(object)
        cuts_in = con.gap < -cfg.check.tolerance  # the real cutter at this pose penetrates
        v[cuts_in & (v != "interference")] = "gouge"
        verdict[rows] = v
    first = cutters[int(ops[0])]
    points = [
        PointResult(
            index=i, kind="cc", move=int(cut[i]), line=int(m.line[cut[i]]),
            cc=tuple(cc[i]), normal=tuple(nrm[i]), tip=tuple(tips[i]), axis=tuple(axes[i]),
            surface=None if sid[i] < 0 else int(sid[i]),
            allowable=float(size[i]) if np.isfinite(size[i]) else None,
            limiting_point=tuple(lim[i]) if np.isfinite(lim[i]).all() else None,
            limiting_surface=None if lsid[i] < 0 else int(lsid[i]),
            verdict=str(verdict[i]),
            margin=float(margin[i]) if np.isfinite(margin[i]) else None,
            depth=float(depth[i]),
        )
        for i in range(n)
    ]
    summary = _summary(points, size, verdict, margin, depth, first, time.perf_counter() - t0)
    job = JobInfo(
        path=str(apt_path), dialect=toolpath.dialect, units=toolpath.units, part=str(ppath),
        part_hash=part.content_hash, cutter=first.to_apt(), cutter_kind=first.kind,
        cutter_size=float(first.size), machine=None if machine is None else str(machine),
        axis_class=axis_class(axes, cfg.four_axis.axis_j_tolerance),
    )
    return ResultsDocument(job=job, summary=summary, points=points)


def _summary(points, size, verdict, margin, depth, cutter, elapsed: float) -> Summary:
    counts = VerdictCounts(**{v: int((verdict == v).sum()) for v in VerdictCounts.model_fields})
    bad = np.flatnonzero(np.isin(verdict, _FINDINGS))
    order = bad[np.lexsort((np.nan_to_num(margin[bad], posinf=1e300), -depth[bad]))][:_WORST]
    worst = [Finding(index=int(i), verdict=str(verdict[i]), line=points[i].line, cc=points[i].cc,
                     depth=float(depth[i]), margin=points[i].margin) for i in order]
    reach = np.isfinite(size) & (verdict != "inaccessible")
    smallest = float(size[reach].min()) if reach.any() else None
    return Summary(
        points=len(points), cc_points=len(points), intermediate_points=0, counts=counts,
        worst_margin=float(margin[reach].min()) if reach.any() else None,
        worst_depth=float(depth.max()) if len(depth) else None,
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
