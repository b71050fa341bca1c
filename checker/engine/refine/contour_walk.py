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
One compiled parallel kernel over the starts. Tool frame through Q; mm."""

from __future__ import annotations

import numba as nb
import numpy as np

from checker.engine.grid.rotations import heights, row_height
from checker.engine.refine.objective import (
    CONTOUR_STEPS,
    Objective,
    onto_floor,
    point_batch,
    surface_size,
)
from checker.engine.refine.row_best import RowBest
from checker.engine.sizes import RowFrame
from checker.geometry.evaluate import eval_range
from checker.part import Part

FIRST_STEP = 0.005  # mm along the contour: the first probe from the start
GOLDEN_ROUNDS = 12  # shrinks the bracket 320-fold: sigma to ~1 micrometre near Pcc, R to ~1e-6 mm
_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
_ON_CONTOUR = 1e-6  # mm: a best point this near its row's bottom plane lies on its contour
_CONTOUR_REACH = 2.0  # test-point spacings searched along the contour either way
_UNBOUNDED_REACH = 8.0  # the same from Pcc, for a row with no size at all
_CHUNK = 16  # starts per parallel task


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
        k = len(rows)
        f, p, q = np.empty(k), np.empty((k, 3)), np.empty((k, 2))
        _walk_all(obj.G, obj.Q, obj.floor, obj.dom, obj.sz, obj.trims,
                  np.ascontiguousarray(rows, dtype=np.int64),
                  np.ascontiguousarray(sid, dtype=np.int64),
                  np.ascontiguousarray(uv, dtype=np.float64), _sigmas(reach * spacing), f, p, q)
        best.evaluations[rows] += _contour_evaluations(reach * spacing)
        best.lower(rows, f, p, sid, q)


def _sigmas(reach: float) -> np.ndarray:
    """0 and the doubling steps up to `reach` mm."""
    count = max(1, int(np.ceil(np.log2(max(reach, FIRST_STEP) / FIRST_STEP))) + 1)
    return np.concatenate([[0.0], FIRST_STEP * 2.0 ** np.arange(count)])


def _contour_evaluations(reach: float) -> int:
    """Exact size evaluations per start of `along_contours` (at most)."""
    return 2 * len(_sigmas(reach)) + GOLDEN_ROUNDS + 3


@nb.njit(cache=True, _nrt=False)
def _on_contour(G, Q, floor, dom, sz, T, r, w, j):
    """Probe j (w.sid, w.u, w.v) moved onto row r's bottom plane from either side (its
    contour), evaluated to order 1; its size into w.size[j]."""
    eval_range(G, w.sid, w.u, w.v, 1, w.ev, w.normals, j, j + 1, w.sc)
    onto_floor(G, Q, dom, r, floor[r], w.sid, w.u, w.v, w.ev, w.normals, w.sc, j, 1, True,
               CONTOUR_STEPS)
    w.size[j] = surface_size(Q, sz, T, r, w.sid[j], w.u[j], w.v[j], w.ev, j)


@nb.njit(cache=True, _nrt=False)
def _at(G, Q, floor, dom, sz, T, r, sd, u0, v0, tu, tv, sigma, w, j):
    """Probe j at `sigma` mm along the contour tangent (tu, tv) ((u, v) per mm) from (u0, v0),
    clipped to the domain and moved onto the contour; its size."""
    w.sid[j] = sd
    w.u[j] = min(max(u0 + sigma * tu, dom[sd, 0, 0]), dom[sd, 0, 1])
    w.v[j] = min(max(v0 + sigma * tv, dom[sd, 1, 0]), dom[sd, 1, 1])
    _on_contour(G, Q, floor, dom, sz, T, r, w, j)
    return w.size[j]


@nb.njit(cache=True, _nrt=False, forceinline=True)
def _slot(side, i, m):
    """The probe slot of sample i (sigma[i]) on `side` (0: along the tangent, 1: against it):
    the start is slot 0 for both, then m - 1 slots a side."""
    return 0 if i == 0 else side * (m - 1) + i


@nb.njit(cache=True, _nrt=False)
def _side(G, Q, floor, dom, sz, T, r, sd, u0, v0, tu, tv, sigma, side, w):
    """The samples at sigma[1:] mm from the start (slot 0) along the contour tangent (tu, tv)
    on `side` (0: along it, 1: against it), into their slots; the index into sigma of the
    smallest of them and the start (the first of equals)."""
    m = sigma.shape[0]
    sign = 1.0 - 2.0 * side
    jb = 0
    for i in range(1, m):
        j = _slot(side, i, m)
        _at(G, Q, floor, dom, sz, T, r, sd, u0, v0, tu * sign, tv * sign, sigma[i], w, j)
        if w.size[j] < w.size[_slot(side, jb, m)]:
            jb = i
    return jb


@nb.njit(cache=True, _nrt=False)
def _walk(G, Q, floor, dom, sz, T, r, sd, u, v, sigma, w, out_p, out_q, k):
    """The smallest size on the contour through (u, v) on surface sd, up to sigma[-1] mm either
    way (module docstring; samples at `sigma (m,)`, sigma[0] = 0 the start); its point and
    (u, v) into out_p[k], out_q[k]."""
    m = sigma.shape[0]
    w.sid[0], w.u[0], w.v[0] = sd, u, v
    _on_contour(G, Q, floor, dom, sz, T, r, w, 0)  # the start, on the contour
    u0, v0 = w.u[0], w.v[0]
    hu, hv = row_height(Q, r, w.ev[0], 1), row_height(Q, r, w.ev[0], 2)
    length = 0.0
    for c in range(3):
        length += (-hv * w.ev[0, 1, c] + hu * w.ev[0, 2, c]) ** 2
    length = max(np.sqrt(length), 1e-300)
    tu, tv = -hv / length, hu / length  # (u, v) per mm along the contour
    j0 = _side(G, Q, floor, dom, sz, T, r, sd, u0, v0, tu, tv, sigma, 0, w)
    j1 = _side(G, Q, floor, dom, sz, T, r, sd, u0, v0, tu, tv, sigma, 1, w)
    side, jb = (0, j0) if w.size[_slot(0, j0, m)] <= w.size[_slot(1, j1, m)] else (1, j1)
    at = _slot(side, jb, m)
    f = w.size[at]
    for c in range(3):
        out_p[k, c] = w.ev[at, 0, c]
    out_q[k, 0], out_q[k, 1] = w.u[at], w.v[at]
    if not np.isfinite(f):
        return f
    sign = 1.0 - 2.0 * side  # golden sections between the smallest sample's neighbours
    su, sv = tu * sign, tv * sign
    j = 2 * m - 1  # the slot of their probes
    a, b = sigma[max(jb - 1, 0)], sigma[min(jb + 1, m - 1)]
    c, d = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
    fc = _at(G, Q, floor, dom, sz, T, r, sd, u0, v0, su, sv, c, w, j)
    fd = _at(G, Q, floor, dom, sz, T, r, sd, u0, v0, su, sv, d, w, j)
    for _ in range(GOLDEN_ROUNDS):
        if fc <= fd:
            b = d
            probe = b - _GOLDEN * (b - a)
            fp = _at(G, Q, floor, dom, sz, T, r, sd, u0, v0, su, sv, probe, w, j)
            c, fc, d, fd = probe, fp, c, fc
        else:
            a = c
            probe = a + _GOLDEN * (b - a)
            fp = _at(G, Q, floor, dom, sz, T, r, sd, u0, v0, su, sv, probe, w, j)
            c, fc, d, fd = d, fd, probe, fp
    last = _at(G, Q, floor, dom, sz, T, r, sd, u0, v0, su, sv, c if fc <= fd else d, w, j)
    if last < f:
        f = last
        for i in range(3):
            out_p[k, i] = w.ev[j, 0, i]
        out_q[k, 0], out_q[k, 1] = w.u[j], w.v[j]
    return f


@nb.njit(cache=True)
def _walk_range(G, Q, floor, dom, sz, T, rows, sid, uv, sigma, f, p, q, k0, k1):
    """`_walk` for the starts k0..k1, with probe scratch of their own."""
    n = 2 * sigma.shape[0]
    w = point_batch(n, 3)
    for k in range(k0, k1):
        f[k] = _walk(G, Q, floor, dom, sz, T, rows[k], sid[k], uv[k, 0], uv[k, 1], sigma, w, p,
                     q, k)


@nb.njit(cache=True, parallel=True)
def _walk_all(G, Q, floor, dom, sz, T, rows, sid, uv, sigma, f, p, q):
    """`_walk` for every start (rows, surfaces, uv (K, 2)) in parallel chunks: the smallest size
    f (K,), its point p (K, 3) (part frame) and (u, v) q (K, 2)."""
    n = rows.shape[0]
    for c in nb.prange((n + _CHUNK - 1) // _CHUNK):
        k0 = np.int64(c) * _CHUNK
        _walk_range(G, Q, floor, dom, sz, T, rows, sid, uv, sigma, f, p, q, k0,
                    min(n, k0 + _CHUNK))
