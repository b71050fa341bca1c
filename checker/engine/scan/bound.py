"""Cheap upper bounds of each CC row's sampled minimum (numba). Any evaluated size bounds the
minimum over all test points from above, so the scan's next pass needs only the points that can
lie below it. Two ways in: the size at about one test point per grid cell of the row's trial
region (`coarse_bounds`), or at given start points, e.g. the minima of nearby rows
(`warm_bounds`); both then descend along the sample graph from the smallest.
(docs/MATH.md §5.2)"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.engine.grid.candidates import (
    SERIAL_ROWS,
    CellGrid,
    cell_misses,
    cell_range,
    grid_view,
    inside,
)
from checker.engine.grid.rotations import in_row_frame, is_identity, rotated
from checker.engine.sizes import SizeArgs, point_size

_COARSE_POINTS = 512  # at most about this many cells per row are sampled by `coarse_bounds`


class Bounds(NamedTuple):
    """Per row (N,): an `upper` bound (mm, inf: none found) of the smallest size over all test
    points, and the kernel `evaluations` spent on it."""

    upper: np.ndarray
    evaluations: np.ndarray


@nb.njit(cache=True, _nrt=False)
def _descend(i, xyz, rot, sz, knn, best, p):
    """Row i: steepest descent along the sample graph `knn` from test point p (-1: none) of
    size `best` (`xyz` the grid's points); returns (size reached, evaluations)."""
    ne = 0
    same = is_identity(rot, i)
    while p >= 0:
        here = p
        p = -1
        for t in range(knn.shape[1]):
            q = knn[here, t]
            if q < 0:
                continue
            x, y, z = in_row_frame(same, rot, i, xyz, q)
            v = point_size(sz, i, x, y, z)
            ne += 1
            if v < best:
                best = v
                p = q
    return best, ne


@nb.njit(cache=True, _nrt=False)
def _coarse_row(i, grid, rot, reg, sz, knn, u, evals):
    """Row i: the first point of every k-th cell column and row under its region (k from
    `_COARSE_POINTS`), where in the region, then the descent from the smallest."""
    xyz_c, order, start, ny = grid.xyz_cells, grid.order, grid.start, grid.ny
    i0, i1, j0, j1 = cell_range(reg, i, grid)
    cells = max(i1 - i0 + 1, 0) * max(j1 - j0 + 1, 0)
    k = max(1, int(math.ceil(math.sqrt(cells / _COARSE_POINTS))))
    view = grid_view(reg, i, rot)
    same = is_identity(rot, i)
    best = np.inf
    arg = np.int64(-1)  # not -1: the descent would also compile for the literal
    ne = 0
    for a in range(i0, i1 + 1, k):
        for c in range(a * ny + j0, a * ny + j1 + 1, k):
            t = start[c]
            if t == start[c + 1] or cell_misses(reg, i, view, grid, c):
                continue
            x, y, z = in_row_frame(same, rot, i, xyz_c, t)
            if not inside(reg, i, x, y, z):
                continue
            v = point_size(sz, i, x, y, z)
            ne += 1
            if v < best:
                best = v
                arg = order[t]
    u[i], more = _descend(i, grid.xyz, rot, sz, knn, best, arg)
    evals[i] = ne + more


@nb.njit(cache=True, _nrt=False)
def _warm_row(i, xyz, rot, sz, knn, starts, u, evals):
    """Row i: the sizes at its start points, then the descent from the smallest (from the
    first start when none is finite)."""
    best = np.inf
    arg = np.int64(-1)  # not -1: the descent would also compile for the literal
    ne = 0
    for k in range(starts.shape[1]):
        p = starts[i, k]
        if p < 0:
            continue
        x, y, z = rotated(rot, i, xyz, p)
        v = point_size(sz, i, x, y, z)
        ne += 1
        if v < best or arg < 0:
            best = v
            arg = p
    u[i], more = _descend(i, xyz, rot, sz, knn, best, arg)
    evals[i] = ne + more


@nb.njit(cache=True, parallel=True)
def _coarse_par(grid, rot, reg, sz, knn, u, evals):
    for i in nb.prange(reg.shape[0]):
        _coarse_row(np.int64(i), grid, rot, reg, sz, knn, u, evals)  # one signature, not uint64


@nb.njit(cache=True)
def _coarse_ser(grid, rot, reg, sz, knn, u, evals):
    for i in range(reg.shape[0]):
        _coarse_row(i, grid, rot, reg, sz, knn, u, evals)


@nb.njit(cache=True, parallel=True)
def _warm_par(xyz, rot, sz, knn, starts, u, evals):
    for i in nb.prange(starts.shape[0]):
        _warm_row(np.int64(i), xyz, rot, sz, knn, starts, u, evals)


@nb.njit(cache=True)
def _warm_ser(xyz, rot, sz, knn, starts, u, evals):
    for i in range(starts.shape[0]):
        _warm_row(i, xyz, rot, sz, knn, starts, u, evals)


def coarse_bounds(grid: CellGrid, rot: np.ndarray, reg: np.ndarray, sz: SizeArgs,
                  knn: np.ndarray) -> Bounds:
    """The rows' bounds from about one point per cell (at most about `_COARSE_POINTS` cells) of
    the region array `reg` (grid/candidates.py) and a descent along the sample graph `knn`.
    `rot (N, 3, 3)`: each row's frame seen from the grid's; `sz`: sizes.size_args of the
    rows."""
    n = len(reg)
    u, evals = np.empty(n), np.empty(n, dtype=np.int64)
    kernel = _coarse_ser if n < SERIAL_ROWS else _coarse_par
    kernel(grid.kernel_args(), rot, reg, sz, knn, u, evals)
    return Bounds(u, evals)


def warm_bounds(xyz: np.ndarray, rot: np.ndarray, starts: np.ndarray, sz: SizeArgs,
                knn: np.ndarray) -> Bounds:
    """The rows' bounds from the test points `starts (N, S)` (-1: none) and a descent along
    the sample graph `knn`. `xyz (M, 3)` the test points by id in some frame (a grid's),
    `rot (N, 3, 3)` each row's frame seen from that one; the other arguments as
    `coarse_bounds`."""
    n = len(starts)
    u, evals = np.empty(n), np.empty(n, dtype=np.int64)
    kernel = _warm_ser if n < SERIAL_ROWS else _warm_par
    kernel(xyz, rot, sz, knn, np.require(starts, np.int64, ("C", "W")), u, evals)  # writable:
    # a read-only array is another signature
    return Bounds(u, evals)
