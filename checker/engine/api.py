"""`allowable(...)`: the allowable cutter size at many CC points (any tool axes). The inputs
checked, the rows' tool frames (grid/), the global scan with sound pruning over the test points
(scan/), the batched local refinement in (u, v) from its starts (refine/), the advice for the
real cutter (advice.py).
(docs/MATH.md §3.7, §5, §6)"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from checker.config import Config, default_config
from checker.engine.advice import advice
from checker.engine.grid.bins import part_tops
from checker.engine.grid.family import family_bounds
from checker.engine.grid.rotations import group_axes, rotate_rows, tool_rotations
from checker.engine.refine.contour_walk import along_contours
from checker.engine.refine.limits import curvature_limit
from checker.engine.refine.rings import ring_evaluations, ring_radii, ring_starts
from checker.engine.refine.row_best import RowBest, sampled
from checker.engine.refine.starts import (
    ON_SURFACE,
    Starts,
    contact_pairs,
    contour_starts,
    per_parameter,
    seam_starts,
    seed_starts,
)
from checker.engine.refine.steps import refine
from checker.engine.scan.bound import warm_bounds
from checker.engine.scan.contour import ContourSeeds
from checker.engine.scan.search import binned_scan
from checker.engine.sizes import RowFrame, horizontal_e, pair_sizes, size_args
from checker.errors import PathcheckError
from checker.geometry.evaluate import evaluate_mixed
from checker.geometry.inverse import invert_points
from checker.geometry.sampling import TestPoints
from checker.part import Part

_KNN = 16
_CONTOUR_SEEDS = 6
_SNAP_ANGLE = 1e-6  # rad: given normals this close to the surface normal are replaced by it
_GRAPH_K = 8
_FIRST_TRIAL = 4.0  # first trial size of the scan at most this many times s0
_HINT_MARGIN = 0.1  # a hinted first trial: this fraction above the hint and the slack
_BOUND_POINTS = 256  # test points (evenly spread over their order) that start `upper_bounds`
_BOUND_BLOCK = 1 << 19  # (row, start point) pairs per call of `upper_bounds`' kernel
_NEAR_ITERATIONS = 2  # refinement steps of `sizes_near` (it starts at minima of nearby axes)


@dataclass
class AllowableResult:
    """Per CC row (N,): `size` allowable size in the cutter's variable (R for flat, bull-nose
    and APT, r for ball and tapered ball), mm, inf = unbounded; `limiting_point (N, 3)` part
    frame, mm (nan if none); `limiting_surface` (-1 if none); `limiting_uv (N, 2)`; `advice`
    for the real cutter (`checker.engine.advice.ADVICE`); `margin` = size - real size (mm);
    `evaluations` of the imaginary size."""

    size: np.ndarray
    limiting_point: np.ndarray
    limiting_surface: np.ndarray
    limiting_uv: np.ndarray
    advice: np.ndarray
    margin: np.ndarray
    evaluations: np.ndarray


class _ToolFrames(NamedTuple):
    """The rows' tool frames: `axes (N, 3)` (axes equal to 12 decimals made one), `Q (K, 3, 3)`
    part -> tool frame of the K `rows (K,)` that face their axis, `faces_away (N,)` the others,
    `frame` the K rows' `RowFrame` (tool frame, mm; None when K = 0)."""

    axes: np.ndarray
    Q: np.ndarray
    faces_away: np.ndarray
    rows: np.ndarray
    frame: RowFrame | None


class _Snapped(NamedTuple):
    """CC points moved onto the surface they lie on (`_snap`): `cc`, `normals (N, 3)`, the
    nearest test point's `surface (N,)` and the `uv (N, 2)` on it (nan: not moved)."""

    cc: np.ndarray
    normals: np.ndarray
    surface: np.ndarray
    uv: np.ndarray


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


def tool_frames(tp: TestPoints, cutter, cc: np.ndarray, normals: np.ndarray, axes: np.ndarray,
                 toward: np.ndarray | None, cfg: Config) -> _ToolFrames:
    """The rows' tool frames (part frame in, unit `normals` and `axes` (N, 3))."""
    keys, group = group_axes(axes)
    axes = keys[group]  # axes equal to 12 decimals are one axis
    Q_keys = tool_rotations(keys)
    Q = Q_keys[group]  # each row's own tool frame
    n_t = rotate_rows(Q, normals)
    faces_away = n_t[:, 2] <= 1e-12
    rows = np.flatnonzero(~faces_away)
    if not rows.size:
        return _ToolFrames(axes, Q[rows], faces_away, rows, None)
    Q, n_t = Q[rows], n_t[rows]
    cc_t = rotate_rows(Q, cc[rows])
    e_t, degen = horizontal_e(n_t, None if toward is None else rotate_rows(Q, toward[rows]))
    tops = part_tops(tp, Q_keys)[group[rows]]  # once per distinct axis
    fam = family_bounds(cutter, cc_t, n_t, e_t, degen, tops)
    return _ToolFrames(axes, Q, faces_away, rows,
                       RowFrame(cc_t, n_t, e_t, fam, cfg.engine.exclusion))


def allowable(test_points: TestPoints, part: Part, cutter, cc, normals, axes=(0.0, 0.0, 1.0), *,
              cc_surface=None, cc_uv=None, toward=None, method: str = "exact",
              seed: int | None = None, config: Config | None = None,
              hint: np.ndarray | None = None) -> AllowableResult:
    """Allowable size at N CC points `cc (N, 3)` with unit normals `normals (N, 3)` (out of the
    material) and tool axes `axes (N, 3)` or (3,) (tip -> spindle), all part frame, mm. The
    minimum over all test points of every surface, refined in (u, v) to the true minimum.
    `cc_surface (N,)`, `cc_uv (N, 2)`: the CC point's own surface and parameters (better
    curvature limit; else the nearest test point's surface is used for the advice). `toward
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
        snapped = _snap(tp, part, cc, normals)
        cc, normals, own, cc_uv = snapped.cc, snapped.normals, snapped.surface, snapped.uv
    else:
        own = np.asarray(cc_surface, dtype=np.int64).reshape(n_rows)
    size = np.full(n_rows, np.inf)
    lim_p = np.full((n_rows, 3), np.nan)
    lim_s = np.full(n_rows, -1, dtype=np.int64)
    lim_uv = np.full((n_rows, 2), np.nan)
    evals = np.zeros(n_rows, dtype=np.int64)
    tf = tool_frames(tp, cutter, cc, normals, axes, tw, cfg)
    rows, faces_away = tf.rows, tf.faces_away
    if rows.size:
        uv_own = None if cc_uv is None else \
            np.asarray(cc_uv, dtype=np.float64).reshape(n_rows, 2)[rows]
        if method == "pso":
            from checker.engine.pso import pso_search

            found = pso_search(part, cutter, tf.frame, tf.Q, np.random.default_rng(seed),
                               cfg.engine)
        else:
            hinted = None if hint is None else np.asarray(hint, dtype=np.float64)[rows]
            found = _exact(tp, part, cutter, tf.frame, tf.Q, tf.axes[rows], own[rows], uv_own, cfg,
                           hinted)
        size[rows], lim_p[rows], lim_s[rows], lim_uv[rows], evals[rows] = (
            found.size, found.point, found.surface, found.uv, found.evaluations)
    size = np.where(size > cfg.engine.max_size, np.inf, size)
    unbounded = ~np.isfinite(size)
    lim_p[unbounded], lim_s[unbounded], lim_uv[unbounded] = np.nan, -1, np.nan
    dist = np.linalg.norm(lim_p - cc, axis=1)
    real = float(cutter.size)
    said = advice(size, real, cfg.check.tolerance, faces_away, (lim_s == own) & (lim_s >= 0),
                  np.where(np.isfinite(dist), dist, np.inf),
                  cfg.check.gouge_neighbourhood * 0.5 * float(cutter.d))
    size[faces_away] = 0.0
    return AllowableResult(size, lim_p, lim_s, lim_uv, said, size - real, evals)


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
        snapped = _snap(tp, part, cc, normals)
        cc, normals = snapped.cc, snapped.normals
    tf = tool_frames(tp, cutter, cc, normals, axes, None, cfg)
    bound[tf.faces_away] = 0.0
    rows = tf.rows
    m = len(tp.points)
    if not rows.size or not m:
        return bound
    starts = np.unique(np.linspace(0, m - 1, min(_BOUND_POINTS, m)).astype(np.int64))
    knn = _neighbours(tp)
    per = max(1, _BOUND_BLOCK // starts.size)
    for a in range(0, len(rows), per):
        r = np.arange(a, min(a + per, len(rows)))
        u = warm_bounds(tp.points, tf.Q[r], np.broadcast_to(starts, (r.size, starts.size)),
                        size_args(cutter, tf.frame, r), knn).upper
        bound[rows[r]] = np.where(u <= cfg.engine.max_size, u, np.inf)
    return bound


def sizes_near(test_points: TestPoints, part: Part, cutter, cc, normals, axes, surface: np.ndarray,
               uv: np.ndarray, *, cc_surface: np.ndarray, cc_uv: np.ndarray,
               config: Config | None = None) -> np.ndarray:
    """(N,) upper bounds (mm, inf: none) of `allowable(...).size` for the same arguments (the
    exact method on a NURBS part, the CC points on their surfaces `cc_surface (N,)` at `cc_uv
    (N, 2)`), from far fewer evaluations: the size refined in (u, v) from the points `uv
    (N, m, 2)` on `surface (N, m)` (-1: none), e.g. where the size was limited at nearby axes,
    and the closed-form limit at the CC point; 0 where the row faces away from its axis.
    Sound: each is the size at a surface point or the limit at the CC point, which the true
    minimum is at most (and below the engine's where its search missed the minimum such a
    start leads to). Tight where the limiting points move little with the axis."""
    cfg = config or default_config()
    cc, normals, axes = _rows(cc, normals, axes)
    out = np.zeros(len(cc))
    tf = tool_frames(test_points, cutter, cc, normals, axes, None, cfg)
    rows = tf.rows
    if not rows.size:
        return out
    own, uv_own = np.asarray(cc_surface, np.int64)[rows], np.asarray(cc_uv, np.float64)[rows]
    size = curvature_limit(cutter, part, tf.frame, tf.Q, np.arange(rows.size), own, uv_own).size
    surface = np.asarray(surface, np.int64)[rows]
    r, j = np.nonzero(surface >= 0)
    if r.size:
        sid, at = surface[r, j], np.asarray(uv, np.float64)[rows][r, j]
        half = 0.5 * test_points.spacing.max()  # the scan's seeds' stencil (refine/starts.py)
        ref = refine(part, cutter, tf.frame, tf.Q, r, sid, at,
                     per_parameter(part, sid, at, np.full(r.size, half)),
                     _NEAR_ITERATIONS)
        np.minimum.at(size, r, ref.size)
    out[rows] = np.where(size > cfg.engine.max_size, np.inf, size)
    return out


_MESH_INDEX: dict[str, object] = {}


def _on_mesh(part: Part, cutter, cc: np.ndarray, normals: np.ndarray, axes: np.ndarray,
             cfg: Config) -> AllowableResult:
    """A mesh part: the allowable size by the exact triangle tests (`mesh.allowable_on_mesh`,
    bisection on the size, up to the part's diagonal: larger is unbounded); no limiting point
    (the bisection gives none); the advice by the same rule as on surfaces, every limit counted
    on the CC point's own surface (a mesh has no surfaces to tell them apart)."""
    from checker.mesh import MeshIndex
    from checker.mesh.allowable import allowable_on_mesh

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
    said = advice(size, float(cutter.size), cfg.check.tolerance, faces_away,
                  np.ones(n, bool), np.zeros(n), 0.0)
    return AllowableResult(size, nowhere, np.full(n, -1, dtype=np.int64),
                           np.full((n, 2), np.nan), said, size - float(cutter.size),
                           np.zeros(n, dtype=np.int64))


def _snap(tp: TestPoints, part: Part, cc: np.ndarray, normals: np.ndarray) -> _Snapped:
    """CC points given without their surface: the nearest surface point (from the nearest test
    point, Gauss-Newton in (u, v)) replaces each one within `ON_SURFACE` mm, and the surface
    normal replaces a given normal within `_SNAP_ANGLE` rad of it (either sign), so that
    rounding in the input does not disturb the sizes near the CC point."""
    _, near = tp.tree.query(cc)
    found = near < len(tp.points)  # a point too far for the tree (1e308) has no nearest one
    near = np.where(found, near, 0)
    own = np.where(found, tp.surface[near] if len(tp.points) else -1, -1).astype(np.int64)
    uv = np.full((len(cc), 2), np.nan)
    out, nrm = cc.copy(), normals.copy()
    for s in np.unique(own[own >= 0]):
        rows = np.flatnonzero(own == s)
        u, v, dist = invert_points(part.surfaces[int(s)], cc[rows], tp.uv[near[rows], 0],
                                   tp.uv[near[rows], 1])
        ok = dist <= ON_SURFACE
        uv[rows[ok]] = np.column_stack([u, v])[ok]
        ev = evaluate_mixed(part, np.full(int(ok.sum()), s), u[ok], v[ok])
        out[rows[ok]] = ev.points
        dot = np.einsum("ij,ij->i", ev.normals, normals[rows[ok]])
        same = np.abs(dot) >= np.cos(_SNAP_ANGLE)
        nrm[rows[ok][same]] = np.sign(dot[same])[:, None] * ev.normals[same]
    return _Snapped(out, nrm, own, uv)


def _exact(tp: TestPoints, part: Part, cutter, frame: RowFrame, Q: np.ndarray, axes: np.ndarray,
           own: np.ndarray, uv_own: np.ndarray | None, cfg: Config,
           hint: np.ndarray | None) -> RowBest:
    """Scan + refinement for rows of any tool axes `axes (N, 3)` (part frame) with tool frames
    `Q (N, 3, 3)`: the scan's sampled minimum, lowered by the refinement from every kind of
    start (refine/starts.py), the limits at the CC point and the walks along the contour."""
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
    best = sampled(tp, sc.minima.best, sc.minima.arg, sc.minima.evaluations + k)
    if not part.surfaces:
        return best
    starts = [seed_starts(tp, part, sc.minima.seeds)]
    if sc.crossings is not None:
        starts.append(contour_starts(tp, part, sc.crossings))
    contacts = None
    if uv_own is not None:
        contacts = contact_pairs(tp, part, knn, own, uv_own, cc_part)
        radii = ring_radii(eng.ring, spacing)
        closed = curvature_limit(cutter, part, frame, Q, contacts.rows, contacts.surface,
                                 contacts.uv)
        toward = rotate_rows(Q.transpose(0, 2, 1), closed.direction, contacts.rows)  # part frame
        ring, at_cc = ring_starts(part, cutter, frame, Q, contacts, radii, toward, closed.settled)
        starts.append(ring)
        np.add.at(best.evaluations, contacts.rows, ring_evaluations(radii))
    starts.append(seam_starts(tp, part, knn, own, spacing))
    start = Starts.join(starts)
    if start.rows.size:
        ref = refine(part, cutter, frame, Q, start.rows, start.surface, start.uv, start.step,
                     eng.refine_iterations)
        np.add.at(best.evaluations, start.rows, ref.evaluations)
        best.lower(start.rows, ref.size, ref.point, start.surface, ref.uv)
    if contacts is not None:
        best.lower(at_cc.rows, at_cc.size, cc_part[at_cc.rows], at_cc.surface, at_cc.uv)
        best.lower(contacts.rows, closed.size, cc_part[contacts.rows], contacts.surface,
                   contacts.uv)
    if cutter.flat_bottomed:
        along_contours(part, cutter, frame, Q, best, cc_part, spacing, own, uv_own)
    return best
