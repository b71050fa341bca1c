"""Seeds on the bottom-plane contour for flat-bottomed cutters (R family, psi = 0).

Nothing below the bottom plane is cut, and just above it the imaginary size rises steeply, so
the minimum often lies on the contour line where the part crosses that plane, between samples.
Every edge of the sample graph (a test point and one of its nearest test points on the same
surface) that straddles the plane gives a crossing point by linear interpolation; the best few
crossings per row (by their size) start the local refinement, which then follows the exact
contour (refine/steps.py). Tool frame, mm."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from checker import kernels
from checker.engine.grid.candidates import CellGrid, cell_heights
from checker.engine.grid.rotations import in_row_frame, is_identity

_EPS_Z = 1e-6  # mm by which a cell must clear the bottom plane to be passed over
_SKIP_MM = 1e-9  # relative and absolute (mm) margin of a bound over the slots against rounding
REACH, LOW = 0, 1  # columns of `EdgeData.edges`


class ContourSeeds(NamedTuple):
    """The crossings wanted per row: at most `count`, at least `separation` mm apart."""

    count: int
    separation: float


class EdgeData(NamedTuple):
    """What `row_crossings` and `straddles` need to pass over points and cells that start no
    crossing (grid frame, mm): per test point `edges (M, 2)` the length of its longest
    sample-graph edge (grown a little against rounding; column REACH) and the lowest height of
    its neighbours (inf: none; column LOW); per cell `nb_lo`, `nb_hi (C, 3)` the corners of the
    box holding its points' neighbours (inf, -inf: none)."""

    edges: np.ndarray
    nb_lo: np.ndarray
    nb_hi: np.ndarray


class Crossings(NamedTuple):
    """Crossings of the bottom plane, seeds of the refinement: the CC `rows (K,)`, the test
    points `p` (at or above the plane) and `q` (below it) of the crossing sample edge and the
    `fraction` of the way from p to q where it crosses the plane."""

    rows: np.ndarray
    p: np.ndarray
    q: np.ndarray
    fraction: np.ndarray

    def where(self, keep: np.ndarray) -> Crossings:
        """The crossings that `keep` selects."""
        return Crossings._make(field[keep] for field in self)

    def renumbered(self, rows: np.ndarray) -> Crossings:
        """The same crossings, row i of a subset of rows being row `rows[i]` of the whole."""
        return self._replace(rows=rows[self.rows])

    @staticmethod
    def join(parts: list[Crossings]) -> Crossings:
        """The crossings of all `parts`, in order."""
        return Crossings._make(np.concatenate(field) for field in zip(*parts, strict=True))


class CrossingSlots(NamedTuple):
    """The best crossings of each row so far, as `row_crossings` fills them, (N, m) each: the
    test points `p` (-1: an empty slot) and `q`, the `fraction` and the `size` (inf: empty) of
    each crossing, and its position `xy (N, m, 2)` (x, y in the row's frame, mm)."""

    p: np.ndarray
    q: np.ndarray
    fraction: np.ndarray
    size: np.ndarray
    xy: np.ndarray

    @staticmethod
    def empty(n: int, m: int) -> CrossingSlots:
        """n rows of m empty slots."""
        return CrossingSlots(np.full((n, m), -1, dtype=np.int64),
                             np.full((n, m), -1, dtype=np.int64), np.zeros((n, m)),
                             np.full((n, m), np.inf), np.zeros((n, m, 2)))

    def found(self) -> Crossings:
        """The crossings in the filled slots, by row."""
        r, c = np.nonzero(np.isfinite(self.size))
        return Crossings(r, self.p[r, c], self.q[r, c], self.fraction[r, c])


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
            edges[p, REACH] = reach * (1.0 + 1e-9) + 1e-9
            edges[p, LOW] = low


def edge_data(grid: CellGrid, knn: np.ndarray) -> EdgeData:
    """The `EdgeData` of the grid's points on the sample graph `knn`, kept in the grid's memo
    for the same `knn`."""
    of_knn, data = grid.memo.get("edges", (None, None))
    if of_knn is not knn:
        cells = len(grid.start) - 1
        data = EdgeData(np.empty((len(grid.xyz), 2)), np.full((cells, 3), np.inf),
                        np.full((cells, 3), -np.inf))
        _edge_data(grid.xyz, knn, grid.order, grid.start, data.edges, data.nb_lo, data.nb_hi)
        grid.memo["edges"] = (knn, data)
    return data


@nb.njit(cache=True, forceinline=True)
def straddles(view, grid, nb_lo, nb_hi, c, floor):
    """Whether cell c can hold a point at or above `floor` (row frame, mm) with a neighbour
    below it (`view`: `grid_view` of the row, grid/candidates.py; boxes from `edge_data`)."""
    if view.ax == 0.0 and view.ay == 0.0 and view.az == 1.0:  # the grid's own z axis
        return grid.box_hi[c, 2] + _EPS_Z >= floor and nb_lo[c, 2] - _EPS_Z < floor
    _, top = cell_heights(view, grid.box_lo, grid.box_hi, c)
    if not top >= floor:
        return False
    low, _ = cell_heights(view, nb_lo, nb_hi, c)
    return low < floor


@nb.njit(cache=True, forceinline=True)
def may_cross(i, rot, xyz, p, zp, floor, edges):
    """Whether a neighbour of point p (at height zp >= floor in row i's frame; `xyz` the grid's
    points by id) can lie below the floor: exactly from the neighbours' lowest height where the
    row's z axis is the grid's, else bounded through the row's tilt (|rot[i, 2] - e_z|) and the
    longest edge."""
    reach, low = edges[p, REACH], edges[p, LOW]
    if zp - floor > reach:
        return False
    if rot[i, 2, 0] == 0.0 and rot[i, 2, 1] == 0.0 and rot[i, 2, 2] == 1.0:
        return low < floor
    tilt = np.sqrt(rot[i, 2, 0] ** 2 + rot[i, 2, 1] ** 2 + (rot[i, 2, 2] - 1.0) ** 2)
    return zp + (low - xyz[p, 2]) - tilt * reach - 1e-9 < floor


@nb.njit(cache=True, _nrt=False)
def row_crossings(i, cand, count, xyz, rot, knn, edges, sz, sep, slots):
    """Up to m crossings of row i, at least `sep` mm apart (the best of each place), from its
    candidate points `cand[:count]` (ids into `xyz`, the grid's frame; the row sees
    `rot[i] @ xyz[p]`; each at or above the plane and admitted by `may_cross`), into row i of
    `slots` (`CrossingSlots`, m slots a row). The bottom plane is at the height z0 of the row in
    `sz` (sizes.size_args); `edges` from `edge_data`. Once the slots are full, a point whose
    crossings all lie above every slot (`kernels.plane_disc_bound` over its longest edge) is
    passed over."""
    cc, n, e, floor, prm = sz.cc, sz.n, sz.e, sz.z0, sz.prm
    out_p, out_q, out_f, out_v, out_x = slots.p, slots.q, slots.fraction, slots.size, slots.xy
    m = out_p.shape[1]
    worst = np.inf  # the largest size in the row's slots (inf while one is empty)
    qz = floor[i] + 1e-9 - cc[i, 2]  # the crossings' height above Pcc
    pd = kernels.plane_disc(qz, n[i, 0], n[i, 1], n[i, 2], e[i, 0], e[i, 1], prm)
    same = is_identity(rot, i)
    for k in range(count):
        p = cand[k]
        xp, yp, zp = in_row_frame(same, rot, i, xyz, p)
        if worst < np.inf:  # every crossing from p lies within its longest edge of it
            low = kernels.plane_disc_bound(pd, xp - cc[i, 0], yp - cc[i, 1], edges[p, REACH])
            if low > worst + _SKIP_MM * (1.0 + worst):
                continue  # above every slot
        for t in range(knn.shape[1]):
            q = knn[p, t]
            if q < 0:
                continue
            xq, yq, zq = in_row_frame(same, rot, i, xyz, q)
            if zq >= floor[i]:
                continue
            f = (zp - floor[i]) / (zp - zq)
            x = xp + f * (xq - xp)
            y = yp + f * (yq - yp)
            v = kernels.apt_size(x - cc[i, 0], y - cc[i, 1], qz,
                                 n[i, 0], n[i, 1], n[i, 2], e[i, 0], e[i, 1], True, prm)
            if not v < worst:  # above every slot: no slot takes it
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
                worst = out_v[i, 0]
                for s in range(1, m):
                    worst = max(worst, out_v[i, s])
