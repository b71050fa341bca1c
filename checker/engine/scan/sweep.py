"""One pass of the global scan over many CC rows (numba): per row, a single traversal of the cell
grid over its trial region gives the imaginary sizes of its test points, the row's sampled
minimum and seeds (basins.py) and, for flat-bottomed cutters, its contour crossings
(contour.py). Tool frame of each row, mm."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from checker.engine.grid.candidates import (
    SERIAL_ROWS,
    CellGrid,
    cell_misses,
    cell_range,
    column_span,
    grid_view,
    inside,
)
from checker.engine.grid.rotations import in_row_frame, is_identity
from checker.engine.scan.basins import row_seeds
from checker.engine.scan.contour import (
    ContourSeeds,
    Crossings,
    CrossingSlots,
    EdgeData,
    may_cross,
    row_crossings,
    straddles,
)
from checker.engine.sizes import SizeArgs, point_size

_BLOCKS_PER_THREAD = 4  # rows are dealt round-robin to this many blocks per thread


class Minima(NamedTuple):
    """Per row: `best (N,)` smallest evaluated size (mm, inf: none), `arg (N,)` its test point
    (-1 none), `seeds (N, m)` test points starting the refinement (-1 pad) and `seed_size
    (N, m)` their sizes (basins.row_seeds), `evaluations (N,)` kernel evaluations spent."""

    best: np.ndarray
    arg: np.ndarray
    seeds: np.ndarray
    seed_size: np.ndarray
    evaluations: np.ndarray

    @staticmethod
    def empty(n: int, m: int) -> Minima:
        """n rows with nothing found yet, m seeds a row."""
        return Minima(np.full(n, np.inf), np.full(n, -1, dtype=np.int64),
                      np.full((n, m), -1, dtype=np.int64), np.full((n, m), np.inf),
                      np.zeros(n, dtype=np.int64))


class Scan(NamedTuple):
    """The result of a scan or of one pass: the rows' `minima` and the `crossings` of their
    bottom-plane contours (None: not wanted)."""

    minima: Minima
    crossings: Crossings | None


class _CrossingInputs(NamedTuple):
    """The crossings wanted, as the kernels take them: `on` (any at all), the arrays of the
    grid's `EdgeData` and the `separation` (mm) of two crossings of a row. Flat: the parallel
    kernel takes no tuple nested in a tuple."""

    on: bool
    nb_lo: np.ndarray
    nb_hi: np.ndarray
    edges: np.ndarray
    separation: float


@nb.njit(cache=True, _nrt=False)
def _traverse(i, grid, rot, reg, lim, sz, on, nb_lo, nb_hi, edges, ids, vals, cand):
    """Row i: the sizes `vals` of its candidates (the points of its region `reg[i]`) that also
    lie in `lim[i]`, with their ids `ids`, in grid order; with crossings `on`, the candidates at
    or above the row's bottom plane (z0 in `sz`) in cells that straddle it and with a neighbour
    that may lie below it go to `cand` (boxes `nb_lo`, `nb_hi` and `edges` from
    contour.edge_data). Returns both counts."""
    xyz, order, start, ny = grid.xyz_cells, grid.order, grid.start, grid.ny
    floor = sz.z0[i]
    view, view_lim = grid_view(reg, i, rot), grid_view(lim, i, rot)
    i0, i1, j0, j1 = cell_range(reg, i, grid)
    k0, k1, l0, l1 = cell_range(lim, i, grid)
    if not on:  # then only the cells that meet `lim` matter
        i0, i1, j0, j1 = max(i0, k0), min(i1, k1), max(j0, l0), min(j1, l1)
    same = is_identity(rot, i)  # the row's frame is the grid's: no rotation per point
    ne = 0
    nc = 0
    for a in range(i0, i1 + 1):
        ja, jb = column_span(reg, i, grid, a, j0, j1)
        la, lb = column_span(lim, i, grid, a, l0, l1) if k0 <= a <= k1 else (l0, l0 - 1)
        if not on:
            ja, jb = max(ja, la), min(jb, lb)
        for j in range(ja, jb + 1):
            c = a * ny + j
            if start[c] == start[c + 1]:
                continue
            evaluate = la <= j <= lb and not cell_misses(lim, i, view_lim, grid, c)
            crossing = on and straddles(view, grid, nb_lo, nb_hi, c, floor)
            if not (evaluate or crossing) or cell_misses(reg, i, view, grid, c):
                continue
            for t in range(start[c], start[c + 1]):
                x, y, z = in_row_frame(same, rot, i, xyz, t)
                if not inside(reg, i, x, y, z):
                    continue
                p = order[t]
                if crossing and z >= floor and may_cross(i, rot, grid.xyz, p, z, floor, edges):
                    cand[nc] = p
                    nc += 1
                if evaluate and inside(lim, i, x, y, z):
                    ids[ne] = p
                    vals[ne] = point_size(sz, i, x, y, z)
                    ne += 1
    return ne, nc


@nb.njit(cache=True)
def _block(b, nblocks, grid, rot, reg, lim, sz, knn, rel, slack, out, cross, found):
    """The rows b, b + nblocks, ... of a pass, with scratch arrays of their own, into `out`
    (`Minima`) and `found` (`CrossingSlots`); `cross` the crossings wanted."""
    best, arg, seeds, seed_size, evals = (out.best, out.arg, out.seeds, out.seed_size,
                                          out.evaluations)
    on, nb_lo, nb_hi, edges, sep = (cross.on, cross.nb_lo, cross.nb_hi, cross.edges,
                                    cross.separation)
    npts = knn.shape[0]
    ids = np.empty(npts, dtype=np.int64)
    vals = np.empty(npts)
    cand = np.empty(npts if on else 0, dtype=np.int64)
    stamp = np.full(npts, -1, dtype=np.int64)
    pos = np.empty(npts, dtype=np.int64)
    low = np.empty(npts)
    for i in range(b, reg.shape[0], nblocks):
        ne, nc = _traverse(i, grid, rot, reg, lim, sz, on, nb_lo, nb_hi, edges, ids, vals, cand)
        evals[i] = ne
        for k in range(ne):
            if vals[k] < best[i]:
                best[i] = vals[k]
                arg[i] = ids[k]
        if best[i] < np.inf:
            row_seeds(i, ids, vals, ne, knn, best[i] * (1.0 + rel) + slack, stamp, pos, low,
                      seeds, seed_size)
        if on:
            row_crossings(i, cand, nc, grid.xyz, rot, knn, edges, sz, sep, found)


@nb.njit(cache=True, parallel=True)
def _sweep_par(nblocks, grid, rot, reg, lim, sz, knn, rel, slack, out, cross, found):
    for b in nb.prange(nblocks):  # np.int64: the index is uint64 here, another signature
        _block(np.int64(b), nblocks, grid, rot, reg, lim, sz, knn, rel, slack, out, cross, found)


@nb.njit(cache=True)
def _sweep_ser(nblocks, grid, rot, reg, lim, sz, knn, rel, slack, out, cross, found):
    for b in range(nblocks):
        _block(b, nblocks, grid, rot, reg, lim, sz, knn, rel, slack, out, cross, found)


def sweep(grid: CellGrid, rot: np.ndarray, reg: np.ndarray, lim: np.ndarray, sz: SizeArgs,
          knn: np.ndarray, m: int, rel: float, slack: float, crossings: ContourSeeds | None = None,
          edges: EdgeData | None = None) -> Scan:
    """One pass over N rows: the test points of each row's region `reg` (grid/candidates.py
    region array) are its candidates, and those also in the region `lim` are evaluated
    (sizes.py, `sz` from `size_args`); seeds up to m per row within `rel * best + slack` mm of
    the best. `rot (N, 3, 3)`: each row's frame seen from the grid's. `crossings`: also that
    many contour crossings per row from all candidates, through the grid's `edges`
    (contour.edge_data)."""
    n = len(reg)
    out = Minima.empty(n, m)
    if crossings is None:
        none = np.zeros((0, 3))
        found = CrossingSlots.empty(0, 1)
        cross = _CrossingInputs(False, none, none, np.zeros((0, 2)), 0.0)
    else:
        found = CrossingSlots.empty(n, crossings.count)
        cross = _CrossingInputs(True, edges.nb_lo, edges.nb_hi, edges.edges,
                                float(crossings.separation))
    kernel, nblocks = ((_sweep_ser, 1) if n < SERIAL_ROWS else
                       (_sweep_par, min(n, _BLOCKS_PER_THREAD * nb.get_num_threads())))
    kernel(nblocks, grid.kernel_args(), rot, reg, lim, sz, knn, rel, slack, out, cross, found)
    return Scan(out, None if crossings is None else found.found())
