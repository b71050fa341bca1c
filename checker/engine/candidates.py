"""Candidate test points per CC row: all points inside a vertical disc and a height slab (tool
frame), found through a uniform 2-D cell grid, returned as CSR lists. Numba-compiled."""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from checker.engine.frames import identity_rows, rotated

SERIAL_ROWS = 64  # below this many rows a kernel runs serially (thread start-up costs more)
_EPS_MM = 1e-9  # mm added to a tilted search disc against rounding


@dataclass
class CellGrid:
    """Test points (tool frame, mm) binned by (x, y) into square cells of side `cell` mm:
    points of cell c are `order[start[c]:start[c + 1]]`; cell (i, j) is `c = i * ny + j`;
    `xyz_cells = xyz[order]` (the points in cell order)."""

    xyz: np.ndarray
    origin: np.ndarray
    cell: float
    nx: int
    ny: int
    start: np.ndarray
    order: np.ndarray
    xyz_cells: np.ndarray


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
    return CellGrid(np.ascontiguousarray(xyz), lo, cell, nx, ny, start, order,
                    np.ascontiguousarray(xyz[order]))


@nb.njit(cache=True)
def _collect_row(i, xyz, lo0, lo1, cell, nx, ny, start, order, bx, by, brad, rot, cx, cy, rad, zlo,
                 zhi, sph, zeq, plane, indptr, out, fill):
    """Candidates of row i: the cells within `brad[i]` of (bx, by)[i] (grid frame), each point
    tested in the row's own frame (`rot[i]` @ grid point). `xyz` in cell order; the cells of a
    grid column form one range of it."""
    i0 = int(min(max(np.floor((bx[i] - brad[i] - lo0) / cell), 0.0), nx - 1.0))
    i1 = int(min(max(np.floor((bx[i] + brad[i] - lo0) / cell), -1.0), nx - 1.0))
    j0 = int(min(max(np.floor((by[i] - brad[i] - lo1) / cell), 0.0), ny - 1.0))
    j1 = int(min(max(np.floor((by[i] + brad[i] - lo1) / cell), -1.0), ny - 1.0))
    r2 = rad[i] * rad[i]
    k = indptr[i]
    cnt = 0
    for a in range(i0, i1 + 1):
        for t in range(start[a * ny + j0], start[a * ny + max(j1, j0 - 1) + 1]):
            x, y, z = rotated(rot, i, xyz, t)
            if z < zlo[i] or z > zhi[i]:
                continue
            if plane[i, 0] * x + plane[i, 1] * y + plane[i, 2] * z < plane[i, 3]:
                continue  # below the tangent plane: no cutter of the family reaches it
            if z < zeq[i]:  # below the equator: inside the sphere or nothing
                sx = x - sph[i, 0]
                sy = y - sph[i, 1]
                sz = z - sph[i, 2]
                if sx * sx + sy * sy + sz * sz > sph[i, 3] * sph[i, 3]:
                    continue
            dx = x - cx[i]
            dy = y - cy[i]
            if dx * dx + dy * dy <= r2:
                if fill:
                    out[k + cnt] = order[t]
                cnt += 1
    if not fill:
        out[i] = cnt


@nb.njit(cache=True, parallel=True)
def _collect_par(xyz, lo0, lo1, cell, nx, ny, start, order, bx, by, brad, rot, cx, cy, rad, zlo,
                 zhi, sph, zeq, plane, indptr, out, fill):
    for i in nb.prange(cx.shape[0]):
        _collect_row(i, xyz, lo0, lo1, cell, nx, ny, start, order, bx, by, brad, rot, cx, cy, rad,
                     zlo, zhi, sph, zeq, plane, indptr, out, fill)


@nb.njit(cache=True)
def _collect_ser(xyz, lo0, lo1, cell, nx, ny, start, order, bx, by, brad, rot, cx, cy, rad, zlo,
                 zhi, sph, zeq, plane, indptr, out, fill):
    for i in range(cx.shape[0]):
        _collect_row(i, xyz, lo0, lo1, cell, nx, ny, start, order, bx, by, brad, rot, cx, cy, rad,
                     zlo, zhi, sph, zeq, plane, indptr, out, fill)


def _search_disc(grid: CellGrid, rot: np.ndarray, centre: np.ndarray, rad: np.ndarray,
                 zlo: np.ndarray, zhi: np.ndarray):
    """Grid-frame discs (centre x, y, radius (N,)) holding every grid point whose row-frame
    image (`rot` @ p) lies in the row's cylinder (`centre`, `rad`, zlo <= z <= zhi). The slab is
    first clipped to the rows' z range of the grid's bounding box; about the cylinder's centre
    C a rotation keeps distances, so a point at height offset w from C moves sideways by at most
    |w| sin(delta), delta the angle between the row's axis and the grid's (sin(delta) =
    |(rot[2, 0], rot[2, 1])|)."""
    lo, hi = grid.xyz.min(axis=0), grid.xyz.max(axis=0)
    r2 = rot[:, 2, :]
    z1 = np.maximum(zlo, np.minimum(r2 * lo, r2 * hi).sum(axis=1))
    z2 = np.minimum(zhi, np.maximum(r2 * lo, r2 * hi).sum(axis=1))
    zm, hz = 0.5 * (z1 + z2), 0.5 * (z2 - z1)
    c = np.einsum("nji,nj->ni", rot, np.column_stack([centre, zm]))  # rot^T C
    sin_d = np.hypot(r2[:, 0], r2[:, 1])
    tilted = sin_d > 0.0
    brad = np.where(tilted, rad + np.abs(hz) * sin_d + _EPS_MM, rad)
    brad = np.where(z2 < z1, -1.0, brad)  # no grid point in the slab
    return np.where(tilted, c[:, 0], centre[:, 0]), np.where(tilted, c[:, 1], centre[:, 1]), brad


def disc_candidates(grid: CellGrid, centre: np.ndarray, radius: np.ndarray, zlo: np.ndarray,
                    zhi: np.ndarray, sphere: np.ndarray, zeq: np.ndarray, plane: np.ndarray,
                    rot: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """CSR (indptr (N+1,), indices (K,)) of the test points within `radius` (N,) mm of `centre`
    (N, 2) horizontally and with zlo <= z <= zhi (tool frame); points below `zeq (N,)` must also
    lie in the ball `sphere (N, 4)` (centre x, y, z, radius); every point must satisfy
    `plane[:, :3] . p >= plane[:, 3]` (the tangent plane lowered by the slack). `rot (N, 3, 3)`:
    each row's own tool frame seen from the grid's (a point p of the grid is `rot[i] @ p` for
    row i; default: the grid's frame)."""
    n = len(radius)
    rad = np.where(np.isfinite(radius), radius, 1e300)
    rot = identity_rows(n) if rot is None else np.ascontiguousarray(rot)
    bx, by, brad = _search_disc(grid, rot, centre, rad, zlo, zhi)
    args = (grid.xyz_cells, float(grid.origin[0]), float(grid.origin[1]), grid.cell, grid.nx,
            grid.ny, grid.start, grid.order, bx, by, brad, rot, np.ascontiguousarray(centre[:, 0]),
            np.ascontiguousarray(centre[:, 1]), rad, zlo, zhi, np.ascontiguousarray(sphere),
            np.ascontiguousarray(zeq), np.ascontiguousarray(plane))
    collect = _collect_ser if n < SERIAL_ROWS else _collect_par
    counts = np.zeros(n, dtype=np.int64)
    collect(*args, np.zeros(n + 1, dtype=np.int64), counts, False)
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    indices = np.empty(indptr[-1], dtype=np.int64)
    collect(*args, indptr, indices, True)
    return indptr, indices
