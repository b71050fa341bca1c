"""A solid stock (or fixture) read from a file and cut into Z-dexels (docs/MATH.md §14): the
material along each vertical ray of a grid is where the ray is inside the closed triangle mesh.
Part frame, mm.

Each triangle adds, to every ray whose (x, y) its projection holds, the z where the ray crosses
it; each ray's crossings, sorted, pair up even-odd into intervals. The xy test is exact: the
vertices' and the rays' x, y are snapped to a common integer grid (2^-k mm, k chosen so that
every coordinate stays below 2^29 units; at most 2^-20 mm on a 500 mm stock) and the edge
functions computed in int64. A ray exactly on an edge or a vertex is counted as the point moved
by the infinitesimal (eps, eps^2) (the rasteriser's top-left rule: on a counter-clockwise edge
u -> v it is inside when v - u points down, or along +x), so each crossing of a closed surface
counts once, however many triangles meet there; triangles seen edge-on add nothing.

A ray with more intervals than the grid's capacity keeps the first capacity - 1 and one last
interval spanning the rest (material added, never lost; counted in `Dexels.overflow`). A ray
with an odd number of crossings (the mesh is not closed there) keeps one interval from its
first crossing to its last (counted in `SolidDexels.unclosed`; a tessellated STEP solid has a
few at its faces' seams, a sheet has nothing else: `require_closed` refuses it)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numba as nb
import numpy as np

from checker.errors import PathcheckError
from checker.stock.dexels import Dexels

if TYPE_CHECKING:
    from checker.config import Config

_INT_BITS = 29  # snapped coordinates below 2^29: edge functions below 2^61 in int64
_MOST_CROSSINGS = 200_000_000  # crossings held at once (1.6 GB of float64)
_MOST_UNCLOSED = 0.01  # share of the material's rays that may cross the mesh an odd number of times


@dataclass
class SolidDexels(Dexels):
    """A solid's dexels; `unclosed` the rays that crossed its mesh an odd number of times."""

    unclosed: int = 0


def _snap_scale(vertices: np.ndarray, x0: float, y0: float, nx: int, ny: int, h: float) -> float:
    """The power of two s such that (coordinate - corner) * s < 2^29 for the vertices and rays."""
    extent = max(float(np.abs(vertices[:, 0] - x0).max(initial=0.0)),
                 float(np.abs(vertices[:, 1] - y0).max(initial=0.0)), nx * h, ny * h, 1e-9)
    return 2.0 ** math.floor(_INT_BITS - math.log2(extent) - 1)


@nb.njit(cache=True, forceinline=True)
def _claims(w: np.int64, dx: np.int64, dy: np.int64) -> bool:
    """Inside the edge whose function is `w` (> 0 inside), a point on it by the top-left rule."""
    return w > 0 or (w == 0 and (dy < 0 or (dy == 0 and dx > 0)))


@nb.njit(cache=True)
def _crossings(qx, qy, z, tri, rx, ry, inv, counts, offsets, zbuf, fill):  # pragma: no cover
    """Count (fill False) or store (fill True, at `offsets`) each ray's crossings. `qx, qy`
    (V,) int64 snapped vertices, `z (V,)`, `tri (T, 3)`, `rx (nx,)`, `ry (ny,)` int64 snapped
    rays, `inv` 1 / (snapped ray spacing), `counts (ny, nx)` int64."""
    nx, ny = rx.shape[0], ry.shape[0]
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        area = (qx[b] - qx[a]) * (qy[c] - qy[a]) - (qy[b] - qy[a]) * (qx[c] - qx[a])
        if area == 0:
            continue
        if area < 0:
            b, c = c, b
            area = -area
        lo_x = min(qx[a], qx[b], qx[c])
        hi_x = max(qx[a], qx[b], qx[c])
        lo_y = min(qy[a], qy[b], qy[c])
        hi_y = max(qy[a], qy[b], qy[c])
        i0 = max(0, int(math.floor((lo_x - rx[0]) * inv)))
        i1 = min(nx - 1, int(math.ceil((hi_x - rx[0]) * inv)))
        j0 = max(0, int(math.floor((lo_y - ry[0]) * inv)))
        j1 = min(ny - 1, int(math.ceil((hi_y - ry[0]) * inv)))
        for j in range(j0, j1 + 1):
            py = ry[j]
            for i in range(i0, i1 + 1):
                px = rx[i]
                # edge functions of the counter-clockwise triangle a, b, c at (px, py)
                w0 = (qx[c] - qx[b]) * (py - qy[b]) - (qy[c] - qy[b]) * (px - qx[b])
                if not _claims(w0, qx[c] - qx[b], qy[c] - qy[b]):
                    continue
                w1 = (qx[a] - qx[c]) * (py - qy[c]) - (qy[a] - qy[c]) * (px - qx[c])
                if not _claims(w1, qx[a] - qx[c], qy[a] - qy[c]):
                    continue
                w2 = (qx[b] - qx[a]) * (py - qy[a]) - (qy[b] - qy[a]) * (px - qx[a])
                if not _claims(w2, qx[b] - qx[a], qy[b] - qy[a]):
                    continue
                if fill:
                    zbuf[offsets[j, i] + counts[j, i]] = (
                        (float(w0) * z[a] + float(w1) * z[b] + float(w2) * z[c]) / float(area))
                counts[j, i] += 1


@nb.njit(cache=True, parallel=True)
def _intervals(counts, offsets, zbuf, lo, hi, count, overflow, unclosed):  # pragma: no cover
    """Per ray: sort its crossings, pair them even-odd, drop empty intervals, join touching
    ones, fold those beyond the capacity into the last."""
    ny, nx = counts.shape
    cap = lo.shape[2]
    for r in nb.prange(ny * nx):
        j, i = r // nx, r % nx
        n = counts[j, i]
        if n == 0:
            continue
        zs = np.sort(zbuf[offsets[j, i]:offsets[j, i] + n])
        pairs = n // 2
        if n % 2 == 1:
            unclosed[j, i] = 1
            pairs = 1
            zs = np.array([zs[0], zs[n - 1]])
        k = 0
        for p in range(pairs):
            a, b = zs[2 * p], zs[2 * p + 1]
            if b <= a:
                continue
            if k > 0 and a <= hi[j, i, k - 1]:
                hi[j, i, k - 1] = max(hi[j, i, k - 1], b)
            elif k < cap:
                lo[j, i, k] = a
                hi[j, i, k] = b
                k += 1
            else:
                hi[j, i, cap - 1] = b
                overflow[j, i] = 1
        count[j, i] = k


def solid_dexels(vertices: np.ndarray, triangles: np.ndarray, x0: float, y0: float, nx: int,
                 ny: int, h: float, capacity: int = 4) -> SolidDexels:
    """The closed mesh `vertices (V, 3)` mm, `triangles (T, 3)` vertex indices as Z-dexels on
    the grid of nx x ny rays at x0 + (i + 0.5) h, y0 + (j + 0.5) h (the module docstring gives
    the rules)."""
    v = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
    tri = np.ascontiguousarray(triangles, dtype=np.int64).reshape(-1, 3)
    e = Dexels.empty(x0, y0, nx, ny, h, capacity)
    out = SolidDexels(e.x0, e.y0, e.h, e.lo, e.hi, e.count)
    if len(tri) == 0 or nx == 0 or ny == 0:
        return out
    s = _snap_scale(v, x0, y0, nx, ny, h)
    qx = np.rint((v[:, 0] - x0) * s).astype(np.int64)
    qy = np.rint((v[:, 1] - y0) * s).astype(np.int64)
    rx = np.rint((np.arange(nx) + 0.5) * h * s).astype(np.int64)
    ry = np.rint((np.arange(ny) + 0.5) * h * s).astype(np.int64)
    inv = 1.0 / (h * s)
    counts = np.zeros((ny, nx), np.int64)
    empty = np.zeros(0)
    _crossings(qx, qy, v[:, 2], tri, rx, ry, inv, counts, counts, empty, False)
    total = int(counts.sum())
    if total > _MOST_CROSSINGS:
        raise PathcheckError(f"the solid crosses the grid's rays {total:,} times (at most "
                             f"{_MOST_CROSSINGS:,}): expected a coarser resolution",
                             code="stock")
    offsets = (np.cumsum(counts.ravel()) - counts.ravel()).reshape(ny, nx)
    zbuf = np.empty(total)
    counts[:] = 0
    _crossings(qx, qy, v[:, 2], tri, rx, ry, inv, counts, offsets, zbuf, True)
    overflow = np.zeros((ny, nx), np.uint8)
    unclosed = np.zeros((ny, nx), np.uint8)
    _intervals(counts, offsets, zbuf, out.lo, out.hi, out.count, overflow, unclosed)
    out.overflow = int(overflow.sum())
    out.unclosed = int(unclosed.sum())
    return out


def require_closed(dexels: SolidDexels, path: str | Path, what: str = "stock solid") -> None:
    """PathcheckError naming `path` when more than 1% of the rays through the solid crossed it
    an odd number of times (a sheet or a mesh with holes, not a solid)."""
    touched = max(int((dexels.count > 0).sum()), dexels.unclosed)
    if dexels.unclosed > _MOST_UNCLOSED * max(touched, 1):
        raise PathcheckError(f"the {what} is not closed: {dexels.unclosed:,} of {touched:,} rays "
                             "through it cross its surface an odd number of times; expected a "
                             "closed solid", path=path, code="stock")


def load_solid(path: str | Path, cfg: Config,
               what: str = "stock solid") -> tuple[np.ndarray, np.ndarray]:
    """`(vertices (V, 3) mm, triangles (T, 3))` of the solid in `path`: an STL as it is, a STEP
    or IGES part's faces as triangles within `cfg.check.part_deviation` (`cfg` a
    `checker.config.Config`); errors name the file as the `what` they are."""
    from checker.geometry import load_part
    from checker.geometry.tessellate import part_triangles

    try:
        part = load_part(Path(path), geometry=cfg.geometry)
        tris = part_triangles(part, cfg.check.part_deviation, cfg.geometry)
    except PathcheckError as err:
        message = err.message.replace("part file", what)
        if what not in message:
            message = f"{what}: {message}"
        raise PathcheckError(message, path=err.path, line=err.line, code=err.code) from None
    return tris.vertices, tris.triangles
