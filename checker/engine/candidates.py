"""Candidate test points per CC row: all points inside a vertical disc and a height slab (tool
frame), found through a uniform 2-D cell grid, returned as CSR lists. Numba-compiled."""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np


@dataclass
class CellGrid:
    """Test points (tool frame, mm) binned by (x, y) into square cells of side `cell` mm:
    points of cell c are `order[start[c]:start[c + 1]]`; cell (i, j) is `c = i * ny + j`."""

    xyz: np.ndarray
    origin: np.ndarray
    cell: float
    nx: int
    ny: int
    start: np.ndarray
    order: np.ndarray


def build_grid(xyz: np.ndarray, per_cell: float = 6.0) -> CellGrid:
    """Bin tool-frame points (M, 3) so that a cell holds about `per_cell` points."""
    xy = xyz[:, :2]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    ext = np.maximum(hi - lo, 1e-9)
    cell = float(max(np.sqrt(ext[0] * ext[1] * per_cell / max(len(xy), 1)), 1e-6 * ext.max(), 1e-9))
    nx, ny = (np.floor(ext / cell).astype(np.int64) + 1).tolist()
    ij = np.minimum(((xy - lo) / cell).astype(np.int64), [nx - 1, ny - 1])
    c = ij[:, 0] * ny + ij[:, 1]
    order = np.argsort(c, kind="stable")
    start = np.searchsorted(c[order], np.arange(nx * ny + 1))
    return CellGrid(np.ascontiguousarray(xyz), lo, cell, nx, ny, start, order)


@nb.njit(cache=True, parallel=True)
def _collect(xyz, lo0, lo1, cell, nx, ny, start, order, cx, cy, rad, zlo, zhi, sph, zeq, plane,
             indptr, out, fill):
    for i in nb.prange(cx.shape[0]):
        r = rad[i]
        i0 = int(min(max(np.floor((cx[i] - r - lo0) / cell), 0.0), nx - 1.0))
        i1 = int(min(max(np.floor((cx[i] + r - lo0) / cell), -1.0), nx - 1.0))
        j0 = int(min(max(np.floor((cy[i] - r - lo1) / cell), 0.0), ny - 1.0))
        j1 = int(min(max(np.floor((cy[i] + r - lo1) / cell), -1.0), ny - 1.0))
        r2 = r * r
        k = indptr[i]
        cnt = 0
        for a in range(i0, i1 + 1):
            for b in range(j0, j1 + 1):
                c = a * ny + b
                for t in range(start[c], start[c + 1]):
                    p = order[t]
                    z = xyz[p, 2]
                    if z < zlo[i] or z > zhi[i]:
                        continue
                    if (plane[i, 0] * xyz[p, 0] + plane[i, 1] * xyz[p, 1] + plane[i, 2] * z
                            < plane[i, 3]):
                        continue  # below the tangent plane: no cutter of the family reaches it
                    if z < zeq[i]:  # below the equator: inside the sphere or nothing
                        sx = xyz[p, 0] - sph[i, 0]
                        sy = xyz[p, 1] - sph[i, 1]
                        sz = z - sph[i, 2]
                        if sx * sx + sy * sy + sz * sz > sph[i, 3] * sph[i, 3]:
                            continue
                    dx = xyz[p, 0] - cx[i]
                    dy = xyz[p, 1] - cy[i]
                    if dx * dx + dy * dy <= r2:
                        if fill:
                            out[k + cnt] = p
                        cnt += 1
        if not fill:
            out[i] = cnt


def disc_candidates(grid: CellGrid, centre: np.ndarray, radius: np.ndarray, zlo: np.ndarray,
                    zhi: np.ndarray, sphere: np.ndarray, zeq: np.ndarray,
                    plane: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR (indptr (N+1,), indices (K,)) of the test points within `radius` (N,) mm of `centre`
    (N, 2) horizontally and with zlo <= z <= zhi (tool frame); points below `zeq (N,)` must also
    lie in the ball `sphere (N, 4)` (centre x, y, z, radius); every point must satisfy
    `plane[:, :3] . p >= plane[:, 3]` (the tangent plane lowered by the slack)."""
    n = len(radius)
    rad = np.where(np.isfinite(radius), radius, 1e300)
    args = (grid.xyz, float(grid.origin[0]), float(grid.origin[1]), grid.cell, grid.nx, grid.ny,
            grid.start, grid.order, np.ascontiguousarray(centre[:, 0]),
            np.ascontiguousarray(centre[:, 1]), rad, zlo, zhi, np.ascontiguousarray(sphere),
            np.ascontiguousarray(zeq), np.ascontiguousarray(plane))
    counts = np.zeros(n, dtype=np.int64)
    _collect(*args, np.zeros(n + 1, dtype=np.int64), counts, False)
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    indices = np.empty(indptr[-1], dtype=np.int64)
    _collect(*args, indptr, indices, True)
    return indptr, indices
