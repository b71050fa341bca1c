"""Candidate test points per CC row: all points inside a vertical disc and a height slab (tool
frame), above a plane and, below an equator, inside a ball, found through a uniform 2-D cell grid.
A row's trial region is one row of a region array (`regions`, `region_rows`). The numba pieces
every traversal shares: `cell_range` and `column_span` (the cells under the region's grid-frame
disc), `cell_misses` (a cell whose bounding box misses the region is passed over) and `inside`
(the exact test of a point)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.engine.grid.family import FamilyBounds

# below this many rows a kernel runs serially (the thread start-up costs more than the rows);
# small enough that a 4-axis job's many small axis bins still run threaded
SERIAL_ROWS = 16
_EPS_MM = 1e-9  # mm added to a tilted search disc against rounding
_CULL_EPS_MM = 1e-6  # mm by which a cell's box must miss a region to be skipped

# Columns of a region array (N, REGION_COLS), each row in its own tool frame, mm: the disc
# (centre, radius), the slab (z low, z high), the ball below `ZEQ` (centre, radius), the plane
# (normal, offset: a point p must have normal . p >= offset) and the disc in the grid's frame
# that holds the region's grid points (centre, radius; -1: no point).
CX, CY, RAD, ZLO, ZHI, SX, SY, SZ, SR, ZEQ, PX, PY, PZ, PD, BX, BY, BRAD = range(17)
REGION_COLS = 17


class GridArrays(NamedTuple):
    """A `CellGrid` as the numba kernels take it (tool frame of the grid, mm)."""

    xyz_cells: np.ndarray  # (M, 3) the points in cell order
    order: np.ndarray  # (M,) point id of each position in cell order
    start: np.ndarray  # (C + 1,) first position of each cell
    x0: float  # corner of cell (0, 0)
    y0: float
    cell: float  # cell side
    nx: int
    ny: int
    box_lo: np.ndarray  # (C, 3) lowest corner of each cell's points (inf: empty)
    box_hi: np.ndarray  # (C, 3) highest corner (-inf: empty)
    xyz: np.ndarray  # (M, 3) the points by id


class GridView(NamedTuple):
    """A row's region seen from the grid's frame (`grid_view`, for `cell_misses`): the row's
    z axis (ax, ay, az), the plane's normal (px, py, pz) and the ball's centre (sx, sy, sz)."""

    ax: float
    ay: float
    az: float
    px: float
    py: float
    pz: float
    sx: float
    sy: float
    sz: float


@dataclass
class CellGrid:
    """Test points (tool frame, mm) binned by (x, y) into square cells of side `cell` mm:
    points of cell c are `order[start[c]:start[c + 1]]`; cell (i, j) is `c = i * ny + j`;
    `xyz_cells = xyz[order]` (the points in cell order); `box_lo`, `box_hi` (C, 3) the corners
    of each cell's bounding box (inf, -inf for an empty cell), `bounds (2, 3)` those of all
    points; `memo` what other modules derive from the grid once."""

    xyz: np.ndarray
    origin: np.ndarray
    cell: float
    nx: int
    ny: int
    start: np.ndarray
    order: np.ndarray
    xyz_cells: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    bounds: np.ndarray
    memo: dict = field(default_factory=dict)

    def kernel_args(self) -> GridArrays:
        """The grid as the numba kernels take it."""
        return GridArrays(self.xyz_cells, self.order, self.start, float(self.origin[0]),
                          float(self.origin[1]), self.cell, self.nx, self.ny, self.box_lo,
                          self.box_hi, self.xyz)


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
    xyz_cells = np.ascontiguousarray(xyz[order])
    box_lo = np.full((nx * ny, 3), np.inf)
    box_hi = np.full((nx * ny, 3), -np.inf)
    full = np.flatnonzero(start[1:] > start[:-1])
    if full.size:
        box_lo[full] = np.minimum.reduceat(xyz_cells, start[full], axis=0)
        box_hi[full] = np.maximum.reduceat(xyz_cells, start[full], axis=0)
    return CellGrid(np.ascontiguousarray(xyz), lo, cell, nx, ny, start, order, xyz_cells, box_lo,
                    box_hi, np.array([xyz.min(axis=0), xyz.max(axis=0)]))


@nb.njit(cache=True, forceinline=True)
def inside(reg, i, x, y, z):
    """Whether the point (x, y, z) (row i's frame, mm) lies in row i's region `reg[i]`: in the
    slab, on or above the plane, in the ball where below `ZEQ`, and in the disc."""
    if z < reg[i, ZLO] or z > reg[i, ZHI]:
        return False
    if reg[i, PX] * x + reg[i, PY] * y + reg[i, PZ] * z < reg[i, PD]:
        return False  # below the tangent plane: no cutter of the family reaches it
    if z < reg[i, ZEQ]:  # below the equator: inside the sphere or nothing
        sx = x - reg[i, SX]
        sy = y - reg[i, SY]
        sz = z - reg[i, SZ]
        if sx * sx + sy * sy + sz * sz > reg[i, SR] * reg[i, SR]:
            return False
    dx = x - reg[i, CX]
    dy = y - reg[i, CY]
    return dx * dx + dy * dy <= reg[i, RAD] * reg[i, RAD]


@nb.njit(cache=True, forceinline=True)
def cell_range(reg, i, grid):
    """Cell columns i0..i1 and rows j0..j1 covering row i's grid-frame disc (empty: i1 < i0 or
    j1 < j0)."""
    x0, y0, cell, nx, ny = grid.x0, grid.y0, grid.cell, grid.nx, grid.ny
    bx, by, br = reg[i, BX], reg[i, BY], reg[i, BRAD]
    i0 = int(min(max(np.floor((bx - br - x0) / cell), 0.0), nx - 1.0))
    i1 = int(min(max(np.floor((bx + br - x0) / cell), -1.0), nx - 1.0))
    j0 = int(min(max(np.floor((by - br - y0) / cell), 0.0), ny - 1.0))
    j1 = int(min(max(np.floor((by + br - y0) / cell), -1.0), ny - 1.0))
    return i0, i1, j0, j1


@nb.njit(cache=True, forceinline=True)
def column_span(reg, i, grid, a, j0, j1):
    """The rows of cell column a, within j0..j1, that meet row i's grid-frame disc (empty:
    second < first); `_CULL_EPS_MM` wider against rounding."""
    x0, y0, cell, nx = grid.x0, grid.y0, grid.cell, grid.nx
    bx, by, br = reg[i, BX], reg[i, BY], reg[i, BRAD]
    left = x0 + a * cell
    dx = left - bx if bx < left else 0.0
    if a < nx - 1:  # the last column also holds the points beyond its right edge
        dx = max(dx, bx - (left + cell))
    dx = max(dx - _CULL_EPS_MM, 0.0)
    if dx > br:
        return j0, j0 - 1
    h = np.sqrt(br * br - dx * dx) + _CULL_EPS_MM
    return (int(max(np.floor((by - h - y0) / cell), j0)),
            int(min(np.floor((by + h - y0) / cell), j1)))


@nb.njit(cache=True, forceinline=True)
def grid_view(reg, i, rot):
    """Row i's `GridView`: its region's axes seen from the grid's frame."""
    px, py, pz = reg[i, PX], reg[i, PY], reg[i, PZ]
    sx, sy, sz = reg[i, SX], reg[i, SY], reg[i, SZ]
    return GridView(rot[i, 2, 0], rot[i, 2, 1], rot[i, 2, 2],
                    px * rot[i, 0, 0] + py * rot[i, 1, 0] + pz * rot[i, 2, 0],
                    px * rot[i, 0, 1] + py * rot[i, 1, 1] + pz * rot[i, 2, 1],
                    px * rot[i, 0, 2] + py * rot[i, 1, 2] + pz * rot[i, 2, 2],
                    sx * rot[i, 0, 0] + sy * rot[i, 1, 0] + sz * rot[i, 2, 0],
                    sx * rot[i, 0, 1] + sy * rot[i, 1, 1] + sz * rot[i, 2, 1],
                    sx * rot[i, 0, 2] + sy * rot[i, 1, 2] + sz * rot[i, 2, 2])


@nb.njit(cache=True, forceinline=True)
def _box(lo, hi, c):
    """Centre and half-sizes (mx, my, mz, hx, hy, hz) of the box `lo[c]`, `hi[c]`."""
    return (0.5 * (hi[c, 0] + lo[c, 0]), 0.5 * (hi[c, 1] + lo[c, 1]), 0.5 * (hi[c, 2] + lo[c, 2]),
            0.5 * (hi[c, 0] - lo[c, 0]), 0.5 * (hi[c, 1] - lo[c, 1]), 0.5 * (hi[c, 2] - lo[c, 2]))


@nb.njit(cache=True, forceinline=True)
def cell_heights(view, lo, hi, c):
    """Lowest and highest row-frame height (mm, widened by _CULL_EPS_MM) over the box `lo[c]`,
    `hi[c]` (grid frame; `view` from `grid_view`)."""
    mx, my, mz, hx, hy, hz = _box(lo, hi, c)
    zc = view.ax * mx + view.ay * my + view.az * mz
    zh = abs(view.ax) * hx + abs(view.ay) * hy + abs(view.az) * hz
    return zc - zh - _CULL_EPS_MM, zc + zh + _CULL_EPS_MM


@nb.njit(cache=True, forceinline=True)
def cell_misses(reg, i, view, grid, c):
    """Whether no point of cell c can lie in row i's region (`view` from `grid_view`): the
    cell's bounding box is outside the grid-frame disc, or (row frame) above or below the slab,
    below the plane, or below the equator and outside the ball, by more than _CULL_EPS_MM."""
    mx, my, mz, hx, hy, hz = _box(grid.box_lo, grid.box_hi, c)
    dx = max(abs(mx - reg[i, BX]) - hx, 0.0)
    dy = max(abs(my - reg[i, BY]) - hy, 0.0)
    far = reg[i, BRAD] + _CULL_EPS_MM
    if dx * dx + dy * dy > far * far:
        return True
    z_lo, z_hi = cell_heights(view, grid.box_lo, grid.box_hi, c)
    if z_hi < reg[i, ZLO] or z_lo > reg[i, ZHI]:
        return True
    top = view.px * mx + view.py * my + view.pz * mz + abs(view.px) * hx + abs(view.py) * hy \
        + abs(view.pz) * hz
    if top < reg[i, PD] - _CULL_EPS_MM:
        return True
    if z_hi < reg[i, ZEQ]:
        ex = max(abs(mx - view.sx) - hx, 0.0)
        ey = max(abs(my - view.sy) - hy, 0.0)
        ez = max(abs(mz - view.sz) - hz, 0.0)
        far = reg[i, SR] + _CULL_EPS_MM
        if ex * ex + ey * ey + ez * ez > far * far:
            return True
    return False


def _search_disc(grid: CellGrid, rot: np.ndarray, centre: np.ndarray, rad: np.ndarray,
                 zlo: np.ndarray, zhi: np.ndarray):
    """Grid-frame discs (centre x, y, radius (N,)) holding every grid point whose row-frame
    image (`rot` @ p) lies in the row's cylinder (`centre`, `rad`, zlo <= z <= zhi). The slab is
    first clipped to the rows' z range of the grid's bounding box; about the cylinder's centre
    C a rotation keeps distances, so a point at height offset w from C moves sideways by at most
    |w| sin(delta), delta the angle between the row's axis and the grid's (sin(delta) =
    |(rot[2, 0], rot[2, 1])|)."""
    lo, hi = grid.bounds
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


def regions(grid: CellGrid, centre: np.ndarray, radius: np.ndarray, zlo: np.ndarray,
            zhi: np.ndarray, sphere: np.ndarray, zeq: np.ndarray, plane: np.ndarray,
            rot: np.ndarray) -> np.ndarray:
    """Region array (N, REGION_COLS) of the rows' tests, each in the row's own tool frame (mm):
    within `radius` (N,) of `centre` (N, 2) horizontally and zlo <= z <= zhi; below `zeq (N,)`
    also inside the ball `sphere (N, 4)` (centre x, y, z, radius); `plane[:, :3] . p >=
    plane[:, 3]`. With the grid-frame discs that hold them: `rot (N, 3, 3)` is each row's tool
    frame seen from the grid's (a grid point p is `rot[i] @ p` in row i's frame)."""
    rad = np.where(np.isfinite(radius), radius, 1e300)
    reg = np.empty((len(rad), REGION_COLS))
    reg[:, CX], reg[:, CY], reg[:, RAD], reg[:, ZLO], reg[:, ZHI] = *centre.T, rad, zlo, zhi
    reg[:, SX:SR + 1], reg[:, ZEQ], reg[:, PX:PD + 1] = sphere, zeq, plane
    reg[:, BX], reg[:, BY], reg[:, BRAD] = _search_disc(grid, rot, centre, rad, zlo, zhi)
    return reg


def region_rows(grid: CellGrid, fam: FamilyBounds, s: np.ndarray, margin: float,
                plane: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Region array of the trial sizes `s (N,)` (finite, mm) of rows with bounds `fam`: every
    test point whose size can be <= s lies in it (family.py), with every bound grown by
    `margin` mm; `plane (N, 4)` the tangent plane lowered by the margin; `rot (N, 3, 3)` as in
    `regions`."""
    sphere, zeq = fam.lower_ball(s, margin)
    return regions(grid, fam.centre(s), fam.radius(s) + margin, fam.z_low(s) - margin,
                   fam.z_top + margin, sphere, zeq, plane, rot)
