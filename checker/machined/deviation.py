"""The signed distance from the simulated stock's surface to the part's surface, measured at
points of the part along their outward normals (docs/MATH.md §15). Part frame, mm.

The stock is a Z-dexel board (`checker.stock.dexels.Dexels`, passed by its arrays so this layer
sits below the stock's): ray (i, j) at x0 + (i + 1/2) h, y0 + (j + 1/2) h holds sorted
intervals [lo, hi] of z and stands for its h x h column. A line through the board is walked
column by column (Amanatides-Woo); in each column its z-range is met with the column's
intervals in closed form, so along the line the model is exact.

At a point p with unit outward normal n:
- p in the model's material: material is left above the design; the deviation is +t, t the
  first exit of the line p + t n (t >= 0) from the material (capped at `reach_left`);
- p outside it: the design was cut into; the deviation is -d, d the Euclidean distance from p
  to the model's material (capped at `reach_cut`: an over-cut at least that deep), found within
  the first entry of the line p - t n into it. An over-cut is a depth below the design like the
  check's penetration; along the normal it would run down a wall cut back beside a face's
  edge."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

_NONE = -1.0


@nb.njit(cache=True, forceinline=True)
def _cell(v: float, origin: float, h: float) -> int:
    return int(math.floor((v - origin) / h))


@nb.njit(cache=True)
def _inside(lo, hi, count, x0, y0, h, x, y, z) -> bool:
    ny, nx = count.shape
    i, j = _cell(x, x0, h), _cell(y, y0, h)
    if i < 0 or j < 0 or i >= nx or j >= ny:
        return False
    for k in range(count[j, i]):  # noqa: SIM110  (numba: no generator in any())
        if lo[j, i, k] <= z <= hi[j, i, k]:
            return True
    return False


@nb.njit(cache=True)
def _walk(lo, hi, count, x0, y0, h, px, py, pz, dx, dy, dz, tmax, enter) -> float:
    """The first t in [0, tmax] where the line p + t d enters (`enter`) or leaves the model's
    material; -1 when it does not within tmax."""
    ny, nx = count.shape
    i, j = _cell(px, x0, h), _cell(py, y0, h)
    si = 1 if dx > 0.0 else -1
    sj = 1 if dy > 0.0 else -1
    big = 1e300
    if abs(dx) > 1e-12:
        tx = ((x0 + (i + (1 if dx > 0.0 else 0)) * h) - px) / dx
        dtx = h / abs(dx)
    else:
        tx, dtx = big, big
    if abs(dy) > 1e-12:
        ty = ((y0 + (j + (1 if dy > 0.0 else 0)) * h) - py) / dy
        dty = h / abs(dy)
    else:
        ty, dty = big, big
    ta = 0.0
    while ta <= tmax:
        tb = min(tx, ty, tmax)
        za, zb = pz + ta * dz, pz + tb * dz
        grid = 0 <= i < nx and 0 <= j < ny
        if enter:
            if grid:
                best = big
                for k in range(count[j, i]):
                    a, b = lo[j, i, k], hi[j, i, k]
                    if a <= za <= b:
                        best = ta
                        break
                    if dz > 0.0 and za < a <= zb:
                        best = min(best, (a - pz) / dz)
                    elif dz < 0.0 and zb <= b < za:
                        best = min(best, (b - pz) / dz)
                if best < big:
                    return max(best, ta)
        else:
            if not grid:
                return ta
            found = False
            top, low = 0.0, 0.0
            for k in range(count[j, i]):
                if lo[j, i, k] <= za <= hi[j, i, k]:
                    found = True
                    low, top = lo[j, i, k], hi[j, i, k]
                    break
            if not found:
                return ta
            if dz > 0.0:
                te = (top - pz) / dz
            elif dz < 0.0:
                te = (low - pz) / dz
            else:
                te = big
            if te < tb:
                return max(te, ta)
        if tb >= tmax:
            break
        if tx <= ty:
            i += si
            tx += dtx
        else:
            j += sj
            ty += dty
        ta = tb
    return _NONE


@nb.njit(cache=True)
def _nearest(lo, hi, count, x0, y0, h, px, py, pz, rmax) -> float:
    """The Euclidean distance from p to the model's material (its rays' h x h columns) when
    below `rmax`, else rmax: columns visited in square rings about p's, until a ring's least
    lateral distance passes the best found."""
    ny, nx = count.shape
    i0, j0 = _cell(px, x0, h), _cell(py, y0, h)
    best = rmax
    k = 0
    while (k - 1) * h < best:
        for j in range(j0 - k, j0 + k + 1):
            if j < 0 or j >= ny:
                continue
            step = 1 if (j == j0 - k or j == j0 + k) else 2 * k
            for i in range(i0 - k, i0 + k + 1, max(step, 1)):
                if i < 0 or i >= nx or count[j, i] == 0:
                    continue
                gx = max(x0 + i * h - px, 0.0, px - (x0 + (i + 1) * h))
                gy = max(y0 + j * h - py, 0.0, py - (y0 + (j + 1) * h))
                g2 = gx * gx + gy * gy
                if g2 >= best * best:
                    continue
                for q in range(count[j, i]):
                    gz = max(lo[j, i, q] - pz, 0.0, pz - hi[j, i, q])
                    d = math.sqrt(g2 + gz * gz)
                    if d < best:
                        best = d
        k += 1
    return best


@nb.njit(cache=True, parallel=True)
def _deviation(lo, hi, count, x0, y0, h, points, normals, reach_left, reach_cut):
    n = len(points)
    out = np.empty(n)
    for p in nb.prange(n):
        px, py, pz = points[p, 0], points[p, 1], points[p, 2]
        nx_, ny_, nz_ = normals[p, 0], normals[p, 1], normals[p, 2]
        if _inside(lo, hi, count, x0, y0, h, px, py, pz):
            t = _walk(lo, hi, count, x0, y0, h, px, py, pz, nx_, ny_, nz_, reach_left, False)
            out[p] = reach_left if t < 0.0 else t
        else:
            t = _walk(lo, hi, count, x0, y0, h, px, py, pz, -nx_, -ny_, -nz_, reach_cut, True)
            out[p] = -_nearest(lo, hi, count, x0, y0, h, px, py, pz,
                               reach_cut if t < 0.0 else t)
    return out


@nb.njit(cache=True, parallel=True)
def _covered(lo, hi, count, x0, y0, h, points, normals, depth):
    n = len(points)
    out = np.zeros(n, np.bool_)
    for p in nb.prange(n):
        out[p] = _walk(lo, hi, count, x0, y0, h, points[p, 0], points[p, 1], points[p, 2],
                       -normals[p, 0], -normals[p, 1], -normals[p, 2], depth, True) >= 0.0
    return out


def _arrays(stock):
    return (stock.lo, stock.hi, stock.count, float(stock.x0), float(stock.y0), float(stock.h))


def signed_deviation(stock, points: np.ndarray, normals: np.ndarray, reach_left: float,
                     reach_cut: float) -> np.ndarray:
    """(N,) mm, the signed deviation of the stock (a `Dexels`) from the design at `points (N,
    3)` with unit outward `normals (N, 3)`: + material left, - over-cut (module docstring),
    within [-reach_cut, reach_left]."""
    p = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
    n = np.ascontiguousarray(normals, np.float64).reshape(-1, 3)
    return _deviation(*_arrays(stock), p, n, float(reach_left), float(reach_cut))


def covered(stock, points: np.ndarray, normals: np.ndarray, depth: float) -> np.ndarray:
    """(N,) bool: the stock has material within `depth` mm of each point along its inward
    normal (or at it): the part's surface there lies in the stock, so a deviation means
    something; elsewhere the stock never reached the design."""
    p = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
    n = np.ascontiguousarray(normals, np.float64).reshape(-1, 3)
    return _covered(*_arrays(stock), p, n, float(depth))


def error_bound(along: float, h: float, normals: np.ndarray,
                deviation: np.ndarray | None = None) -> np.ndarray:
    """(N,) mm: the bound on each point's deviation. Along the line the model is exact, so
    what the removal is short by along a ray (`along`, `checker.stock.removal.error_bound`)
    carries over; laterally each ray stands for its h x h column, which places the stock's
    surface within h/sqrt(2) horizontally: a layer left parallel to the design within
    h/sqrt(2) |n_xy| along the normal, an over-cut's Euclidean depth (`deviation` < 0) within
    h/sqrt(2) (docs/MATH.md §15.2)."""
    nxy = np.hypot(normals[:, 0], normals[:, 1])
    if deviation is not None:
        nxy = np.where(np.asarray(deviation) < 0.0, 1.0, nxy)
    return along + h / math.sqrt(2.0) * nxy
