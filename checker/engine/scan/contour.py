"""Seeds on the bottom-plane contour for flat-bottomed cutters (R family, psi = 0).

Nothing below the bottom plane is cut, and just above it the imaginary size rises steeply, so
the minimum often lies on the contour line where the part crosses that plane, between samples.
Every edge of the sample graph (a test point and one of its nearest test points on the same
surface) that straddles the plane gives a crossing point by linear interpolation; the best few
crossings per row (by their size) start the local refinement, which then follows the exact
contour (refine/steps.py). Tool frame, mm."""

from __future__ import annotations

import numba as nb
import numpy as np

from checker import kernels
from checker.engine.grid.candidates import CellGrid, cell_heights
from checker.engine.grid.frames import rotated

_EPS_Z = 1e-6  # mm by which a cell must clear the bottom plane to be passed over


@nb.njit(cache=True)
def _edge_data(xyz, knn, order, start, edges, nb_lo, nb_hi):
    """The arrays of `edge_data`, filled."""
    for c in range(start.shape[0] - 1):
        for t in range(start[c], start[c + 1]):
            p = order[t]
            reach = 0.0
            low = np.inf
            for k in range(knn.shape[1]):
                q = knn[p, k]
                if q < 0:
                    continue
                d = 0.0
                for j in range(3):
                    d += (xyz[q, j] - xyz[p, j]) ** 2
                    nb_lo[c, j] = min(nb_lo[c, j], xyz[q, j])
                    nb_hi[c, j] = max(nb_hi[c, j], xyz[q, j])
                reach = max(reach, np.sqrt(d))
                low = min(low, xyz[q, 2])
            edges[p, 0] = reach * (1.0 + 1e-9) + 1e-9
            edges[p, 1] = low


def edge_data(grid: CellGrid, knn: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What `row_crossings` and `straddles` need to pass over points and cells that start no
    crossing (grid frame, mm): per test point (M, 2) the length of its longest sample-graph edge
    (grown a little against rounding) and the lowest height of its neighbours (inf: none); per
    cell (C, 3) the corners of the box holding its points' neighbours (inf, -inf: none). Kept
    in the grid's memo for the same `knn`."""
    hit = grid.memo.get("edges")
    if hit is None or hit[0] is not knn:
        cells = len(grid.start) - 1
        edges = np.empty((len(grid.xyz), 2))
        nb_lo, nb_hi = np.full((cells, 3), np.inf), np.full((cells, 3), -np.inf)
        _edge_data(grid.xyz, knn, grid.order, grid.start, edges, nb_lo, nb_hi)
        hit = grid.memo["edges"] = (knn, (edges, nb_lo, nb_hi))
    return hit[1]


@nb.njit(cache=True, inline="always")
def straddles(view, grid, nb_lo, nb_hi, c, floor):
    """Whether cell c can hold a point at or above `floor` (row frame, mm) with a neighbour
    below it (`view`: `grid_view` of the row, grid/candidates.py; boxes from `edge_data`)."""
    if view[0] == 0.0 and view[1] == 0.0 and view[2] == 1.0:  # the grid's own z axis
        return grid.box_hi[c, 2] + _EPS_Z >= floor and nb_lo[c, 2] - _EPS_Z < floor
    top = cell_heights(view, grid.box_lo, grid.box_hi, c)[1]
    return top >= floor and cell_heights(view, nb_lo, nb_hi, c)[0] < floor


@nb.njit(cache=True, inline="always")
def _may_cross(i, rot, xyz, p, zp, floor, edges):
    """Whether a neighbour of point p (at height zp >= floor in row i's frame) can lie below
    the floor: exactly from the neighbours' lowest height where the row's z axis is the grid's,
    else bounded through the row's tilt (|rot[i, 2] - e_z|) and the longest edge."""
    reach, low = edges[p, 0], edges[p, 1]
    if zp - floor > reach:
        return False
    if rot[i, 2, 0] == 0.0 and rot[i, 2, 1] == 0.0 and rot[i, 2, 2] == 1.0:
        return low < floor
    tilt = np.sqrt(rot[i, 2, 0] ** 2 + rot[i, 2, 1] ** 2 + (rot[i, 2, 2] - 1.0) ** 2)
    return zp + (low - xyz[p, 2]) - tilt * reach - 1e-9 < floor


@nb.njit(cache=True)
def row_crossings(i, cand, count, xyz, rot, knn, edges, sz, sep, out_p, out_q, out_f, out_v,
                  out_x):
    """Up to m = `out_p.shape[1]` crossings of row i, at least `sep` mm apart (the best of each
    place), from its candidate points `cand[:count]` (ids into `xyz`, the grid's frame; the row
    sees `rot[i] @ xyz[p]`), into row i of the `out_*` arrays: p, q, fraction, size and (x, y)
    of the crossing. The bottom plane is at the height z0 of the row in `sz`
    (sizes.size_args); `edges` from `edge_data`."""
    cc, n, e, floor, prm = sz.cc, sz.n, sz.e, sz.z0, sz.prm
    m = out_p.shape[1]
    for k in range(count):
        p = cand[k]
        xp, yp, zp = rotated(rot, i, xyz, p)
        if zp < floor[i] or not _may_cross(i, rot, xyz, p, zp, floor[i], edges):
            continue
        for t in range(knn.shape[1]):
            q = knn[p, t]
            if q < 0:
                continue
            xq, yq, zq = rotated(rot, i, xyz, q)
            if zq >= floor[i]:
                continue
            f = (zp - floor[i]) / (zp - zq)
            x = xp + f * (xq - xp)
            y = yp + f * (yq - yp)
            v = kernels.apt_size(x - cc[i, 0], y - cc[i, 1], floor[i] + 1e-9 - cc[i, 2],
                                 n[i, 0], n[i, 1], n[i, 2], e[i, 0], e[i, 1], True, prm)
            if not v < np.inf:
                continue
            slot = -1  # the seed of the same place, else the worst seed
            for s in range(m):
                dx, dy = out_x[i, s, 0] - x, out_x[i, s, 1] - y
                if out_p[i, s] >= 0 and dx * dx + dy * dy < sep * sep:
                    slot = s
                    break
            if slot < 0:
                slot = 0
                for s in range(1, m):
                    if out_v[i, s] > out_v[i, slot]:
                        slot = s
            if v < out_v[i, slot]:
                out_v[i, slot], out_p[i, slot], out_q[i, slot], out_f[i, slot] = v, p, q, f
                out_x[i, slot, 0], out_x[i, slot, 1] = x, y
