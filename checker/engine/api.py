"""`allowable(...)`: the allowable cutter size at many CC points (any tool axes): global scan with
sound pruning over the test points, batched local refinement in (u, v), verdicts.
(docs/MATH.md §3.7, §5, §6)"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.config import Config, default_config
from checker.engine.grid.bins import part_tops
from checker.engine.grid.family import family_bounds
from checker.engine.grid.frames import group_axes, heights, rotate_rows, tool_rotations
from checker.engine.refine import limits
from checker.engine.refine.contour_walk import contour_evaluations, contour_minimum
from checker.engine.refine.steps import Objective, refine
from checker.engine.scan.bound import warm_bounds
from checker.engine.scan.contour import ContourSeeds
from checker.engine.scan.search import binned_scan
from checker.engine.sizes import RowFrame, horizontal_e, pair_sizes, size_args
from checker.engine.verdict import verdicts
from checker.errors import PathcheckError
from checker.geometry.evaluate import evaluate_mixed
from checker.geometry.fundamental import uv_of_tangents
from checker.geometry.inverse import invert_points
from checker.geometry.sampling import TestPoints
from checker.part import Part

_KNN = 16
_CONTOUR_SEEDS = 6
_SNAP = 1e-3  # mm: CC points this close to a surface are moved onto it
_SNAP_ANGLE = 1e-6  # rad: given normals this close to the surface normal are replaced by it
_GRAPH_K = 8
_FIRST_TRIAL = 4.0  # first trial size of the scan at most this many times s0
_HINT_MARGIN = 0.1  # a hinted first trial: this fraction above the hint and the slack
_FIRST_RING = 16  # directions on the first ring around a CC point
_RING_RATIO = 3.0  # the wider rings' radii grow by at most this
_ON_CONTOUR = 1e-6  # mm: a best point this near its row's bottom plane lies on its contour
_CONTOUR_REACH = 2.0  # test-point spacings searched along the contour either way
_BOUND_POINTS = 256  # test points (evenly spread over their order) that start `upper_bounds`
_BOUND_BLOCK = 1 << 19  # (row, start point) pairs per call of `upper_bounds`' kernel


@dataclass
class AllowableResult:
    """Per CC row (N,): `size` allowable size in the cutter's variable (R for flat, bull-nose
    and APT, r for ball and tapered ball), mm, inf = unbounded; `limiting_point (N, 3)` part
    frame, mm (nan if none); `limiting_surface` (-1 if none); `limiting_uv (N, 2)`; `verdict`
    for the real cutter; `margin` = size - real size (mm); `evaluations` of the imaginary size."""

    size: np.ndarray
    limiting_point: np.ndarray
    limiting_surface: np.ndarray
    limiting_uv: np.ndarray
    verdict: np.ndarray
    margin: np.ndarray
    evaluations: np.ndarray


def _rows3(a, n: int | None, what: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1 and arr.shape == (3,) and n is not None:
        arr = np.broadcast_to(arr, (n, 3))
    if arr.ndim != 2 or arr.shape[1] != 3 or (n is not None and arr.shape[0] != n):
        raise PathcheckError(f"{what}: expected an (N, 3) array, found shape {arr.shape}",
                             code="input")
    if not np.isfinite(arr).all():
        raise PathcheckError(f"{what}: expected finite numbers, found nan or inf", code="input")
    return np.ascontiguousarray(arr)


def _unit(a: np.ndarray, what: str) -> np.ndarray:
    norm = np.linalg.norm(a, axis=1)
    if (norm < 1e-12).any():
        raise PathcheckError(f"{what}: expected non-zero vectors, found a zero vector at row "
                             f"{int(np.argmax(norm < 1e-12))}", code="input")
    return a / norm[:, None]


def _neighbours(tp: TestPoints) -> np.ndarray:
    """(M, 8) nearest other test points of every test point on the same surface (-1 where the
    neighbour is on another surface; cached): the sample graph in which the scan looks for
    local minima, so that every surface gets its own seeds."""
    cache = tp.cache("engine.api")
    hit = cache.get("knn")
    if hit is None:
        k = min(_GRAPH_K + 1, len(tp.points))
        _, nb = tp.tree.query(tp.points, k=k)
        nb = nb.reshape(len(tp.points), k)[:, 1:]
        other = tp.surface[nb] != tp.surface[:, None]  # basins do not reach across seams
        hit = np.ascontiguousarray(np.where(other, -1, nb), dtype=np.int64)
        cache["knn"] = hit
    return hit


def _rows(cc, normals, axes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The CC points (N, 3), unit normals and unit axes (N, 3; one (3,) axis broadcast) of a
    call, checked (PathcheckError naming the argument)."""
    cc = _rows3(cc, None, "cc")
    return (cc, _unit(_rows3(normals, len(cc), "normals"), "normals"),
            _unit(_rows3(axes, len(cc), "axes"), "axes"))


def _tool_frames(tp: TestPoints, cutter, cc: np.ndarray, normals: np.ndarray, axes: np.ndarray,
                 toward: np.ndarray | None, cfg: Config):
    """The rows' tool frames (part frame in, unit `normals` and `axes` (N, 3)): (axes (N, 3),
    axes equal to 12 decimals made one; `Q (K, 3, 3)` part -> tool frame of the K rows that
    face the axis; `faces_away (N,)`; those rows `rows (K,)`; their `RowFrame` (tool frame,
    mm), None when K = 0)."""
    keys, group = group_axes(axes)
    axes = keys[group]  # axes equal to 12 decimals are one axis
    Q = tool_rotations(axes)  # each row's own tool frame
    n_t = rotate_rows(Q, normals)
    faces_away = n_t[:, 2] <= 1e-12
    rows = np.flatnonzero(~faces_away)
    if not rows.size:
        return axes, Q[rows], faces_away, rows, None
    Q, n_t = Q[rows], n_t[rows]
    cc_t = rotate_rows(Q, cc[rows])
    e_t, degen = horizontal_e(n_t, None if toward is None else rotate_rows(Q, toward[rows]))
    fam = family_bounds(cutter, cc_t, n_t, e_t, degen, part_tops(tp, Q))
    return axes, Q, faces_away, rows, RowFrame(cc_t, n_t, e_t, fam, cfg.engine.exclusion)


def allowable(test_points: TestPoints, part: Part, cutter, cc, normals, axes=(0.0, 0.0, 1.0), *,
              cc_surface=None, cc_uv=None, toward=None, method: str = "exact",
              seed: int | None = None, config: Config | None = None,
              hint: np.ndarray | None = None) -> AllowableResult:
    """Allowable size at N CC points `cc (N, 3)` with unit normals `normals (N, 3)` (out of the
    material) and tool axes `axes (N, 3)` or (3,) (tip -> spindle), all part frame, mm. The
    minimum over all test points of every surface, refined in (u, v) to the true minimum.
    `cc_surface (N,)`, `cc_uv (N, 2)`: the CC point's own surface and parameters (better
    curvature limit; else the nearest test point's surface is used for the verdict). `toward
    (N, 3)`: a direction from the CC point towards the tool axis (from the CL data) for normals
    along the axis. `method`: "exact" (this engine) or "pso" (thesis baseline, `seed`).
    `hint (N,)`: sizes expected (mm, e.g. at a nearby axis; nan: none): a first trial of the
    scan just above them, which only the time depends on."""
    cfg = config or default_config()
    if method not in ("exact", "pso"):
        raise PathcheckError(f"unknown method '{method}', expected 'exact' or 'pso'", code="input")
    cc, normals, axes = _rows(cc, normals, axes)
    n_rows = len(cc)
    if part.mesh is not None:
        return _on_mesh(part, cutter, cc, normals, axes, cfg)
    tw = None if toward is None else _rows3(toward, n_rows, "toward")
    tp = test_points
    if cc_surface is None:
        cc, normals, own, cc_uv = _snap(tp, part, cc, normals)
    else:
        own = np.asarray(cc_surface, dtype=np.int64).reshape(n_rows)
    size = np.full(n_rows, np.inf)
    lim_p = np.full((n_rows, 3), np.nan)
    lim_s = np.full(n_rows, -1, dtype=np.int64)
    lim_uv = np.full((n_rows, 2), np.nan)
    evals = np.zeros(n_rows, dtype=np.int64)
    axes, Q, faces_away, rows, frame = _tool_frames(tp, cutter, cc, normals, axes, tw, cfg)
    if rows.size:
        uv_own = None if cc_uv is None else \
            np.asarray(cc_uv, dtype=np.float64).reshape(n_rows, 2)[rows]
        if method == "pso":
            from checker.engine.pso import pso_search

            found = pso_search(part, cutter, frame, Q, np.random.default_rng(seed), cfg.engine)
        else:
            hinted = None if hint is None else np.asarray(hint, dtype=np.float64)[rows]
            found = _exact(tp, part, cutter, frame, Q, axes[rows], own[rows], uv_own, cfg, hinted)
        s, p, sid, uv, ev = found
        size[rows], lim_p[rows], lim_s[rows], lim_uv[rows], evals[rows] = s, p, sid, uv, ev
    size = np.where(size > cfg.engine.max_size, np.inf, size)
    unbounded = ~np.isfinite(size)
    lim_p[unbounded], lim_s[unbounded], lim_uv[unbounded] = np.nan, -1, np.nan
    dist = np.linalg.norm(lim_p - cc, axis=1)
    real = float(cutter.size)
    verdict = verdicts(size, real, cfg.check.tolerance, faces_away, (lim_s == own) & (lim_s >= 0),
                       np.where(np.isfinite(dist), dist, np.inf),
                       cfg.check.gouge_neighbourhood * 0.5 * float(cutter.d))
    size[faces_away] = 0.0
    return AllowableResult(size, lim_p, lim_s, lim_uv, verdict, size - real, evals)


def upper_bounds(test_points: TestPoints, part: Part, cutter, cc, normals, axes, *,
                 cc_surface=None, config: Config | None = None) -> np.ndarray:
    """(N,) upper bounds (mm, inf: none) of `allowable(...).size` for the same arguments (the
    exact method), far cheaper: 0 where the row faces away from its axis, else the smallest
    size at `_BOUND_POINTS` test points spread over the part and along the descent from the
    smallest of them on the sample graph. Sound: the engine's size is at most the smallest
    size over all test points (the scan's exact minimum, which the refinement only lowers),
    where that is within `max_size`. A mesh part has none (inf)."""
    cfg = config or default_config()
    cc, normals, axes = _rows(cc, normals, axes)
    bound = np.full(len(cc), np.inf)
    if part.mesh is not None:
        return bound
    tp = test_points
    if cc_surface is None:
        cc, normals, _, _ = _snap(tp, part, cc, normals)
    _, Q, faces_away, rows, frame = _tool_frames(tp, cutter, cc, normals, axes, None, cfg)
    bound[faces_away] = 0.0
    m = len(tp.points)
    if not rows.size or not m:
        return bound
    starts = np.unique(np.linspace(0, m - 1, min(_BOUND_POINTS, m)).astype(np.int64))
    knn = _neighbours(tp)
    per = max(1, _BOUND_BLOCK // starts.size)
    for a in range(0, len(rows), per):
        r = np.arange(a, min(a + per, len(rows)))
        u = warm_bounds(tp.points, Q[r], np.broadcast_to(starts, (r.size, starts.size)),
                        size_args(cutter, frame, r), knn).upper
        bound[rows[r]] = np.where(u <= cfg.engine.max_size, u, np.inf)
    return bound


_MESH_INDEX: dict[str, object] = {}


def _on_mesh(part: Part, cutter, cc: np.ndarray, normals: np.ndarray, axes: np.ndarray,
             cfg: Config) -> AllowableResult:
    """A mesh part: the allowable size by the exact triangle tests (`mesh.allowable_on_mesh`,
    bisection on the size, up to the part's diagonal: larger is unbounded); no limiting point
    (the bisection gives none); verdicts by the same rule as on surfaces, every limit counted
    on the CC point's own surface (a mesh has no surfaces to tell them apart)."""
    from checker.mesh import MeshIndex
    from checker.mesh.depth import allowable_on_mesh

    m = part.mesh
    index = _MESH_INDEX.get(part.content_hash)
    if index is None:
        _MESH_INDEX.clear()  # one mesh kept: the service's part cache keeps the others
        index = _MESH_INDEX[part.content_hash] = MeshIndex.build(m.vertices, m.triangles)
    n = len(cc)
    faces_away = np.einsum("ij,ij->i", normals, axes) <= 1e-12
    size = np.zeros(n)
    cap = min(cfg.engine.max_size, float(np.linalg.norm(np.ptp(m.vertices, axis=0))))
    ok = ~faces_away
    if ok.any():
        size[ok] = allowable_on_mesh(index, cutter, cc[ok], normals[ok], axes[ok],
                                     tol=max(cfg.check.tolerance, 1e-6), s_max=cap)
    nowhere = np.full((n, 3), np.nan)
    verdict = verdicts(size, float(cutter.size), cfg.check.tolerance, faces_away,
                       np.ones(n, bool), np.zeros(n), 0.0)
    return AllowableResult(size, nowhere, np.full(n, -1, dtype=np.int64),
                           np.full((n, 2), np.nan), verdict, size - float(cutter.size),
                           np.zeros(n, dtype=np.int64))


def _snap(tp: TestPoints, part: Part, cc: np.ndarray, normals: np.ndarray):
    """CC points given without their surface: the nearest surface point (from the nearest test
    point, Gauss-Newton in (u, v)) replaces each one within `_SNAP` mm, and the surface normal
    replaces a given normal within `_SNAP_ANGLE` rad of it (either sign), so that rounding in
    the input does not disturb the sizes near the CC point. Returns (cc, normals, surface (N,),
    uv (N, 2))."""
    _, near = tp.tree.query(cc)
    own = tp.surface[near].astype(np.int64)
    uv = np.full((len(cc), 2), np.nan)
    out, nrm = cc.copy(), normals.copy()
    for s in np.unique(own[own >= 0]):
        rows = np.flatnonzero(own == s)
        u, v, dist = invert_points(part.surfaces[int(s)], cc[rows], tp.uv[near[rows], 0],
                                   tp.uv[near[rows], 1])
        ok = dist <= _SNAP
        uv[rows[ok]] = np.column_stack([u, v])[ok]
        ev = evaluate_mixed(part, np.full(int(ok.sum()), s), u[ok], v[ok])
        out[rows[ok]] = ev.points
        dot = np.einsum("ij,ij->i", ev.normals, normals[rows[ok]])
        same = np.abs(dot) >= np.cos(_SNAP_ANGLE)
        nrm[rows[ok][same]] = np.sign(dot[same])[:, None] * ev.normals[same]
    return out, nrm, own, uv


def _exact(tp: TestPoints, part: Part, cutter, frame: RowFrame, Q: np.ndarray, axes: np.ndarray,
           own: np.ndarray, uv_own: np.ndarray | None, cfg: Config, hint: np.ndarray | None):
    """Scan + refinement for rows of any tool axes `axes (N, 3)` (part frame) with tool frames
    `Q (N, 3, 3)`; returns per row (size, limiting point (part frame), surface, uv,
    evaluations)."""
    eng = cfg.engine
    n = len(frame.cc)
    rows = np.arange(n)
    k = min(_KNN, len(tp.points))
    cc_part = rotate_rows(Q.transpose(0, 2, 1), frame.cc)
    _, knn = tp.tree.query(cc_part, k=k)
    knn = knn.reshape(n, k)
    s_ub = pair_sizes(cutter, frame, np.repeat(rows, k),
                      rotate_rows(Q, tp.points[knn.ravel()], np.repeat(rows, k)))
    s_ub = s_ub.reshape(n, k).min(axis=1)
    spacing = float(tp.spacing.max()) if len(tp.spacing) else 0.0
    slack = 0.5 * spacing + cfg.geometry.sag_tolerance
    s0 = max(float(cutter.size), 4.0 * spacing, 1e-3)
    s_start = np.where(np.isfinite(s_ub), s_ub, s0)
    flat = cutter.flat_bottomed
    cross = ContourSeeds(_CONTOUR_SEEDS, 0.5 * spacing) if flat and part.surfaces else None
    # s_start can be far above the minimum (a convex spot); a small first trial finds the same
    # answer from fewer candidates (scan: `first`). Contour crossings need the full disc.
    first = None if cross is not None else np.minimum(s_start, _FIRST_TRIAL * s0)
    if first is not None and hint is not None:
        near = (hint + slack) * (1.0 + _HINT_MARGIN) + slack
        first = np.where(np.isfinite(near) & (near > 0.0), np.minimum(first, near), first)
    sc = binned_scan(tp, cutter, frame, Q, axes, s_start, eng.max_size, slack, eng.refine_seeds,
                     _neighbours(tp), cross, first)
    size, arg = sc.minima.best.copy(), sc.minima.arg
    has = arg >= 0
    lim_p = np.full((n, 3), np.nan)
    lim_p[has] = tp.points[arg[has]]
    lim_s = np.where(has, tp.surface[np.maximum(arg, 0)], -1).astype(np.int64)
    lim_uv = np.full((n, 2), np.nan)
    lim_uv[has] = tp.uv[arg[has]]
    evals = sc.minima.evaluations + k
    if not part.surfaces:
        return size, lim_p, lim_s, lim_uv, evals
    srow, ssid, suv, sstep = _seed_starts(tp, part, sc, spacing)
    if sc.crossings is not None:
        extra = _contour_starts(tp, part, sc.crossings)
        srow, ssid, suv, sstep = (np.concatenate([a, b]) for a, b in
                                  zip((srow, ssid, suv, sstep), extra, strict=True))
    pairs = None
    if uv_own is not None:
        pairs = _contact_pairs(tp, part, knn, own, uv_own, cc_part)
        radii = _ring_radii(eng.ring, spacing)
        closed = limits.curvature_limit(cutter, part, frame, Q, *pairs)
        toward = rotate_rows(Q.transpose(0, 2, 1), closed.direction, pairs[0])  # part frame
        ring, at_cc = _ring_starts(part, cutter, frame, Q, *pairs, radii, toward)
        srow, ssid, suv, sstep = (np.concatenate([a, b]) for a, b in
                                  zip((srow, ssid, suv, sstep), ring, strict=True))
        np.add.at(evals, pairs[0], _FIRST_RING + 10 * (len(radii) - 1))
    seam = _seam_starts(tp, part, knn, own, spacing)
    srow, ssid, suv, sstep = (np.concatenate([a, b]) for a, b in
                              zip((srow, ssid, suv, sstep), seam, strict=True))
    best = (size, lim_p, lim_s, lim_uv)
    if srow.size:
        ref = refine(part, cutter, frame, Q, srow, ssid, suv, sstep, eng.refine_iterations)
        np.add.at(evals, srow, ref.evaluations)
        _keep_smaller(best, srow, ref.size, ref.point, ssid, ref.uv)
    if pairs is not None:
        lrow, lsize, lsid, luv = at_cc
        _keep_smaller(best, lrow, lsize, cc_part[lrow], lsid, luv)
    if pairs is not None:
        prow, psid, puv = pairs
        _keep_smaller(best, prow, closed.size, cc_part[prow], psid, puv)
    if cutter.flat_bottomed:
        _along_contours(part, cutter, frame, Q, best, cc_part, spacing, evals)
    return size, lim_p, lim_s, lim_uv, evals


def _along_contours(part: Part, cutter, frame: RowFrame, Q: np.ndarray, best: tuple,
                    cc_part: np.ndarray, spacing: float, evals: np.ndarray) -> None:
    """Flat-bottomed cutters: where a row's best point lies on its bottom plane's contour (or
    is Pcc itself, the curvature limit), the contour searched in one dimension from there
    (contour_walk.py) may lower it (in place)."""
    size, point, sid, uv = best
    height = np.full(len(size), np.inf)
    ok = np.isfinite(size) & (sid >= 0) & np.isfinite(uv).all(axis=1)
    rows = np.flatnonzero(ok)
    height[rows] = heights(Q, point[rows], rows) - frame.fam.z0[rows]
    at_cc = np.linalg.norm(point - cc_part, axis=1) <= frame.exclusion
    rows = np.flatnonzero(ok & ((np.abs(height) <= _ON_CONTOUR) | at_cc))
    if not rows.size:
        return
    obj = Objective(part, cutter, frame, Q)
    f, p, q = contour_minimum(obj, rows, sid[rows], uv[rows], _CONTOUR_REACH * spacing)
    evals[rows] += contour_evaluations(spacing * _CONTOUR_REACH)
    _keep_smaller(best, rows, f, p, sid[rows], q)


def _keep_smaller(best: tuple, rows: np.ndarray, size: np.ndarray, point: np.ndarray,
                  sid: np.ndarray, uv: np.ndarray) -> None:
    """Per row, the smallest of the candidates (rows (K,), size, point, surface, uv) replaces
    `best` = (size (N,), point (N, 3), surface (N,), uv (N, 2)) where it is smaller (in place)."""
    order = np.lexsort((size, rows))
    first = np.ones(order.size, dtype=bool)
    first[1:] = rows[order][1:] != rows[order][:-1]
    pick = order[first]
    r = rows[pick]
    better = size[pick] < best[0][r]
    r, pick = r[better], pick[better]
    best[0][r], best[1][r], best[2][r], best[3][r] = size[pick], point[pick], sid[pick], uv[pick]


def _seed_starts(tp: TestPoints, part: Part, sc, spacing: float):
    """Refinement starts from the scan's seeds: rows, surfaces, uv and stencil half-widths."""
    srow, col = np.nonzero(sc.minima.seeds >= 0)
    idx = sc.minima.seeds[srow, col]
    keep = tp.surface[idx] >= 0
    srow, idx = srow[keep], idx[keep]
    sid = tp.surface[idx].astype(np.int64)
    uv = tp.uv[idx]
    return srow, sid, uv, _per_parameter(part, sid, uv, 0.5 * tp.spacing[idx])


def _contour_starts(tp: TestPoints, part: Part, crossings: tuple):
    """Refinement starts on the bottom-plane contour of flat-bottomed cutters (contour.py):
    rows, surfaces, uv interpolated along the crossing sample edges, stencil half-widths."""
    rows, p, q, f = crossings
    sid = tp.surface[p].astype(np.int64)
    uv = tp.uv[p] + f[:, None] * (tp.uv[q] - tp.uv[p])
    return rows, sid, uv, _per_parameter(part, sid, uv, 0.25 * tp.spacing[p])


def _per_parameter(part: Part, sid: np.ndarray, uv: np.ndarray, mm: np.ndarray) -> np.ndarray:
    """(K, 2) lengths `mm (K,)` expressed in u and in v at the surface points (sid, uv):
    mm / |S_u|, mm / |S_v|."""
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1])
    return np.column_stack([mm / np.maximum(np.linalg.norm(ev.du, axis=1), 1e-12),
                            mm / np.maximum(np.linalg.norm(ev.dv, axis=1), 1e-12)])


def _nearest_of_surface(sid: np.ndarray) -> np.ndarray:
    """(N, k) mask of the entries of sorted nearest-neighbour rows whose surface `sid (N, k)`
    no nearer entry of the row has: the nearest test point of each surface."""
    first = np.ones(sid.shape, dtype=bool)
    for j in range(1, sid.shape[1]):
        first[:, j] = (sid[:, :j] != sid[:, j:j + 1]).all(axis=1)
    return first


def _contact_pairs(tp: TestPoints, part: Part, knn: np.ndarray, own: np.ndarray,
                   uv_own: np.ndarray, cc: np.ndarray):
    """(rows (K,), surfaces (K,), uv (K, 2)): every surface each CC point `cc (N, 3)` (part
    frame) lies on: its own (`own`, `uv_own`, where known) and, on a seam, every other surface
    of its nearest test points `knn (N, k)` that passes within `_SNAP` mm of it (uv by
    inversion from that test point)."""
    has = (own >= 0) & np.isfinite(uv_own).all(axis=1)
    rows, sids, uvs = [np.flatnonzero(has)], [own[has]], [uv_own[has]]
    sid = tp.surface[knn]
    r, j = np.nonzero(_nearest_of_surface(sid) & (sid != own[:, None]) & (sid >= 0))
    idx = knn[r, j]
    for s in np.unique(tp.surface[idx]):
        sel = np.flatnonzero(tp.surface[idx] == s)
        u, v, dist = invert_points(part.surfaces[int(s)], cc[r[sel]], tp.uv[idx[sel], 0],
                                   tp.uv[idx[sel], 1])
        ok = dist <= _SNAP
        rows.append(r[sel][ok])
        sids.append(np.full(int(ok.sum()), s, dtype=np.int64))
        uvs.append(np.column_stack([u, v])[ok])
    return np.concatenate(rows), np.concatenate(sids).astype(np.int64), np.concatenate(uvs)


def _seam_starts(tp: TestPoints, part: Part, knn: np.ndarray, own: np.ndarray, spacing: float):
    """Where the CC point lies on or near a seam: among its nearest test points, the nearest one
    on each other surface within one spacing starts a refinement (the rings cover the surfaces
    the CC point lies on, these the ones it only comes near)."""
    n, k = knn.shape
    sid = tp.surface[knn]
    rows = np.repeat(np.arange(n), k)
    d = np.linalg.norm(tp.points[knn] - tp.points[knn[:, :1]], axis=2)  # from the nearest one
    pick = (_nearest_of_surface(sid) & (sid != own[:, None]) & (sid >= 0) & (d <= spacing)).ravel()
    idx = knn.ravel()[pick]
    sid = tp.surface[idx].astype(np.int64)
    return rows[pick], sid, tp.uv[idx], _per_parameter(part, sid, tp.uv[idx],
                                                       0.25 * tp.spacing[idx])


def _ring_radii(ring: float, spacing: float) -> list[float]:
    """The rings probed around a CC point (mm): `ring` (its own curvature), then radii growing by
    at most _RING_RATIO up to half the test-point spacing, and 1.5 spacings. Near the CC point
    the size is the curvature limit plus a term linear in the distance (third-order contact),
    so a minimum can lie at any distance below the samples' resolution, where no Newton walk
    from the first ring reaches it (a cone's tip); a ring within a factor of it does."""
    top = max(0.5 * spacing, ring)
    count = int(np.ceil(np.log(top / ring) / np.log(_RING_RATIO))) + 1
    return [*np.geomspace(ring, top, max(count, 2)).tolist(), 1.5 * spacing]


def _ring_starts(part: Part, cutter, frame: RowFrame, Q: np.ndarray, rows: np.ndarray,
                 sid: np.ndarray, uv: np.ndarray, radii: list[float], toward: np.ndarray):
    """Around each CC point, on each surface it lies on (pairs rows (K,), sid (K,), uv (K, 2)),
    points on rings of `radii` (mm) in directions even in the tangent plane (not in (u, v)):
    _FIRST_RING of them on the first ring, which probes the curvature limit at the CC point; the
    direction of the closed-form limit (`toward (K, 3)`, part frame, NaN where none: limits.py),
    else the first ring's best (interpolated between the samples), and the opposite one, with 8
    even ones, on every wider ring: the narrow valleys near the CC point that the samples do not
    resolve leave it along that direction (a sector a few degrees wide at 0.01 mm). The best
    point of each ring is a refinement start (stencil half-width: the first ring's radius, then
    half the ring's). Returns the starts (rows, sid, uv, half-widths) and the limits at the CC
    points themselves (rows, size, sid, uv): along the best direction the size is
    s0 + b rho + O(rho^2) (third-order contact); where b > 0 the infimum is s0, at the CC point,
    which no point reaches: extrapolated from rho and rho/2 (Richardson) where the closed form
    does not apply (docs/MATH.md §6.2, §6.3)."""
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1])
    dom = part.domains
    lo, hi = dom[sid, :, 0], dom[sid, :, 1]
    per_mm = 1.0 / np.maximum(np.column_stack([np.linalg.norm(ev.du, axis=1),
                                               np.linalg.norm(ev.dv, axis=1)]), 1e-12)
    to_uv = _tangent_to_uv(ev.du, ev.dv)
    even = np.arange(8) * np.pi / 4
    first = np.arange(_FIRST_RING) * 2 * np.pi / _FIRST_RING
    angles = np.broadcast_to(first, (len(rows), _FIRST_RING))
    out = []
    for j, radius in enumerate(radii):
        m = angles.shape[1]
        step = radius * to_uv(angles)  # (K, m, 2)
        ring = np.clip(uv[:, None, :] + step, lo[:, None], hi[:, None])
        pts = evaluate_mixed(part, np.repeat(sid, m), ring[..., 0].ravel(),
                             ring[..., 1].ravel()).points
        f = pair_sizes(cutter, frame, np.repeat(rows, m),
                       rotate_rows(Q, pts, np.repeat(rows, m))).reshape(-1, m)
        k = np.argmin(f, axis=1)
        ar = np.arange(len(rows))
        ok = np.isfinite(f[ar, k])
        half = radius * per_mm * (1.0 if j == 0 else 0.5)
        out.append((rows[ok], sid[ok], ring[ar, k][ok], half[ok]))
        if j == 0:
            t1, t2 = _tangent_basis(ev.du, ev.dv)
            known = np.isfinite(toward).all(axis=1)  # the closed form's direction (limits.py)
            best = np.where(known, np.arctan2(np.einsum("ij,ij->i", toward, t2),
                                              np.einsum("ij,ij->i", toward, t1)),
                            _best_angle(f, first))
            at_cc = _limit_at_cc(cutter, frame, Q, part, rows, sid, uv, lo, hi, to_uv, best,
                                 radius, ~known)
            angles = np.column_stack([best, best + np.pi, np.broadcast_to(even, (len(rows), 8))])
    return tuple(np.concatenate([o[t] for o in out]) for t in range(4)), at_cc


def _limit_at_cc(cutter, frame: RowFrame, Q: np.ndarray, part: Part, rows, sid, uv, lo, hi,
                 to_uv, angle: np.ndarray, radius: float, wanted: np.ndarray):
    """(rows, size, sid, uv): the size's limit at the `wanted` CC points (`_ring_starts`;
    the others have it in closed form) along `angle`, 2 s(rho/2) - s(rho) with rho = `radius`;
    the opposite direction where that one leaves the surface's domain (a CC point on its
    boundary; the curvature is the same); docs/MATH.md §6.3."""
    step = radius * to_uv(angle[:, None])[:, 0]
    out = (uv + step < lo) | (uv + step > hi)
    step = np.where(out.any(axis=1)[:, None], -step, step)
    near = np.clip(uv + 0.5 * step, lo, hi)
    far = np.clip(uv + step, lo, hi)
    pts = evaluate_mixed(part, np.tile(sid, 2), np.r_[near[:, 0], far[:, 0]],
                         np.r_[near[:, 1], far[:, 1]]).points
    f = pair_sizes(cutter, frame, np.tile(rows, 2), rotate_rows(Q, pts, np.tile(rows, 2)))
    f_near, f_far = f[:len(rows)], f[len(rows):]
    ok = np.isfinite(f_near) & np.isfinite(f_far) & wanted
    limit = np.maximum(np.minimum(2.0 * f_near[ok] - f_far[ok], f_near[ok]), 0.0)
    return rows[ok], limit, sid[ok], uv[ok]


def _tangent_basis(du: np.ndarray, dv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangent vectors (K, 3) at K surface points: du's direction, and the normal
    cross it."""
    t1 = du / np.maximum(np.linalg.norm(du, axis=1, keepdims=True), 1e-300)
    nrm = np.cross(du, dv)
    return t1, np.cross(nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300), t1)


def _tangent_to_uv(du: np.ndarray, dv: np.ndarray):
    """`f(angles (K, m)) -> (K, m, 2)`: the (u, v) steps of unit length in the tangent plane at
    K surface points (derivatives du, dv (K, 3)), at `angles` (rad) from du's direction."""
    t1, t2 = _tangent_basis(du, dv)
    to_uv = uv_of_tangents(du, dv)

    def f(angles: np.ndarray) -> np.ndarray:
        return to_uv(np.cos(angles)[..., None] * t1[:, None]
                     + np.sin(angles)[..., None] * t2[:, None])

    return f


def _best_angle(f: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(K,) the angle of the smallest of K rows of values `f (K, m)` at even `angles (m,)`,
    between the samples by a parabola through the best and its two neighbours (the sample
    where they are not finite)."""
    m = len(angles)
    k = np.argmin(f, axis=1)
    ar = np.arange(len(f))
    a, b, c = f[ar, (k - 1) % m], f[ar, k], f[ar, (k + 1) % m]
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = 0.5 * (a - c) / (a - 2.0 * b + c)
    shift = np.where(np.isfinite(shift), np.clip(shift, -0.5, 0.5), 0.0)
    return angles[k] + shift * (2.0 * np.pi / m)
