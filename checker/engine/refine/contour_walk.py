"""The smallest size along the bottom-plane contour, for flat-bottomed cutters (R family, psi = 0).

Above the bottom plane a flat end-mill's size depends on the horizontal position only (R =
|d|^2 / (2 e.d)), and its level lines are circles through Pcc tangent to the contour there; the
part's points above the plane that a cutter can reach lie between the contour and that tangent,
where R is larger than on the contour at the same distance. So the minimum lies on the contour,
a curve along which R is smooth, while across it R jumps to inf just below and rises steeply
just above: a two-dimensional search near the contour stalls, most of all next to Pcc, where
every level circle passes (docs/MATH.md §6.4). Here the contour is searched in one dimension:
from a start on it (a row's best point on the plane, or Pcc itself), in both directions, the
points `contour(sigma)` (the start's contour tangent, sigma mm along it, moved onto the plane
by Newton steps on the height) at sigma growing by doubling up to `reach`, then golden-section
search between the neighbours of the smallest, on the side whose samples reach lower. Exact
sizes of real surface points throughout, so a result can only lower a row's answer soundly.
Tool frame through Q; mm."""

from __future__ import annotations

import numpy as np

from checker.engine.grid.frames import heights
from checker.engine.refine.best import RowBest
from checker.engine.refine.objective import Objective, SurfaceSizes
from checker.engine.sizes import RowFrame
from checker.part import Part

FIRST_STEP = 0.005  # mm along the contour: the first probe from the start
GOLDEN_ROUNDS = 12  # shrinks the bracket 320-fold: sigma to ~1 micrometre near Pcc, R to ~1e-6 mm
_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
_ON_CONTOUR = 1e-6  # mm: a best point this near its row's bottom plane lies on its contour
_CONTOUR_REACH = 2.0  # test-point spacings searched along the contour either way
_UNBOUNDED_REACH = 8.0  # the same from Pcc, for a row with no size at all


def along_contours(part: Part, cutter, frame: RowFrame, Q: np.ndarray, best: RowBest,
                   cc_part: np.ndarray, spacing: float, own: np.ndarray,
                   uv_own: np.ndarray | None) -> None:
    """Flat-bottomed cutters: where a row's best point lies on its bottom plane's contour (or
    is Pcc itself, the curvature limit; `cc_part (N, 3)` part frame), the contour searched in
    one dimension from there, up to `_CONTOUR_REACH` test-point `spacing`s either way, may
    lower it (in place). A row with no size at all searches the contour through Pcc (surface
    `own (N,)`, parameters `uv_own (N, 2)`) up to `_UNBOUNDED_REACH` spacings: where the part
    rises above the plane only in a sliver narrower than the samples (at a surface's edge), no
    sample is cut, and the contour leads there (docs/MATH.md §6.4)."""
    height = np.full(len(best.size), np.inf)
    ok = np.isfinite(best.size) & (best.surface >= 0) & np.isfinite(best.uv).all(axis=1)
    rows = np.flatnonzero(ok)
    height[rows] = heights(Q, best.point[rows], rows) - frame.fam.z0[rows]
    at_cc = np.linalg.norm(best.point - cc_part, axis=1) <= frame.exclusion
    rows = np.flatnonzero(ok & ((np.abs(height) <= _ON_CONTOUR) | at_cc))
    walks = [(rows, best.surface[rows], best.uv[rows], _CONTOUR_REACH)]
    if uv_own is not None:
        rows = np.flatnonzero(~np.isfinite(best.size) & (own >= 0))
        walks.append((rows, own[rows], uv_own[rows], _UNBOUNDED_REACH))
    walks = [walk for walk in walks if walk[0].size]
    if not walks:
        return
    obj = Objective(part, cutter, frame, Q)
    for rows, sid, uv, reach in walks:
        f, p, q = _contour_minimum(obj, rows, sid, uv, reach * spacing)
        best.evaluations[rows] += _contour_evaluations(reach * spacing)
        best.lower(rows, f, p, sid, q)


def _sigmas(reach: float) -> np.ndarray:
    """0 and the doubling steps up to `reach` mm."""
    count = max(1, int(np.ceil(np.log2(max(reach, FIRST_STEP) / FIRST_STEP))) + 1)
    return np.concatenate([[0.0], FIRST_STEP * 2.0 ** np.arange(count)])


def _contour_evaluations(reach: float) -> int:
    """Exact size evaluations per start of `_contour_minimum` (at most)."""
    return 2 * len(_sigmas(reach)) + GOLDEN_ROUNDS + 3


def _contour_minimum(obj: Objective, rows: np.ndarray, sid: np.ndarray, uv: np.ndarray,
                     reach: float):
    """(size (K,), point (K, 3) part frame, uv (K, 2)): the smallest size found on the contour
    through each start (rows, surfaces, uv (K, 2)), up to `reach` mm from it either way."""
    rows2, sid2 = np.tile(rows, 2), np.tile(sid, 2)
    start = obj.on_contour(rows2, sid2, np.tile(uv[:, 0], 2), np.tile(uv[:, 1], 2))
    f0, p0, uv0 = start.size, start.point, start.uv
    tangent = _contour_tangent(obj, rows2, start.ev) * np.repeat([1.0, -1.0], len(rows))[:, None]
    sigma = _sigmas(reach)  # (m,)

    lo, hi = obj.dom[sid2, :, 0], obj.dom[sid2, :, 1]

    def at(s: np.ndarray, k: np.ndarray) -> SurfaceSizes:
        """The sizes at sigma `s` along the contours of walkers `k`."""
        w = np.clip(uv0[k] + s[:, None] * tangent[k], lo[k], hi[k])
        return obj.on_contour(rows2[k], sid2[k], w[:, 0], w[:, 1])

    k2, m, half = len(rows2), len(sigma), len(rows)
    grid = at(np.tile(sigma[1:], k2), np.repeat(np.arange(k2), m - 1))
    fg, pg, qg = grid.size, grid.point, grid.uv
    f_grid = np.column_stack([f0, fg.reshape(k2, m - 1)])
    p_grid = np.concatenate([p0[:, None], pg.reshape(k2, m - 1, 3)], axis=1)
    q_grid = np.concatenate([uv0[:, None], qg.reshape(k2, m - 1, 2)], axis=1)
    j = np.argmin(f_grid, axis=1)
    # per start the direction whose samples reach lower, refined by golden section there
    ar = np.arange(half)
    side = np.where(f_grid[ar, j[:half]] <= f_grid[ar + half, j[half:]], ar, ar + half)
    f, p, q = f_grid[side, j[side]], p_grid[side, j[side]], q_grid[side, j[side]]
    go = np.flatnonzero(np.isfinite(f))
    walkers, jg = side[go], j[side[go]]
    a, b = sigma[np.maximum(jg - 1, 0)], sigma[np.minimum(jg + 1, m - 1)]
    c, d = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
    fc, fd = at(c, walkers).size, at(d, walkers).size
    for _ in range(GOLDEN_ROUNDS):
        left = fc <= fd
        b, a = np.where(left, d, b), np.where(left, a, c)
        probe = np.where(left, b - _GOLDEN * (b - a), a + _GOLDEN * (b - a))
        fp = at(probe, walkers).size
        c, fc, d, fd = (np.where(left, probe, d), np.where(left, fp, fd),
                        np.where(left, c, probe), np.where(left, fc, fp))
    last = at(np.where(fc <= fd, c, d), walkers)
    fg, pg, qg = last.size, last.point, last.uv
    better = fg < f[go]
    f[go[better]], p[go[better]], q[go[better]] = fg[better], pg[better], qg[better]
    return f, p, q


def _contour_tangent(obj: Objective, rows: np.ndarray, ev) -> np.ndarray:
    """(K, 2) the (u, v) step per mm along the contour (the height's level line) at points of
    order-1 evaluation `ev`: (-h_v, h_u) scaled to unit length in space."""
    hu = heights(obj.Q, ev.du, rows)
    hv = heights(obj.Q, ev.dv, rows)
    w = np.column_stack([-hv, hu])
    length = np.linalg.norm(w[:, :1] * ev.du + w[:, 1:] * ev.dv, axis=1)
    return w / np.maximum(length, 1e-300)[:, None]

