"""A surface's (u, v) grid cut to its trim: the kept region of a `UVTrim` as a polygon (GEOS,
through shapely), and the triangles that tile it exactly, cell by cell: a cell that no trim
loop crosses is kept whole (two triangles) or dropped; a cell a loop crosses is clipped to the
region and the pieces triangulated (constrained Delaunay), so a strip along a trim edge or a
face narrower than a cell is covered too. MATH.md §8.2. Parameters (u, v) only: the caller
evaluates the vertices on the surface."""

from __future__ import annotations

from functools import reduce
from typing import NamedTuple

import numpy as np
import shapely

from checker.part import Surface

_MIN_AREA = 1e-14  # relative to the cell's area: slivers below it carry no surface


class TrimmedGrid(NamedTuple):
    """`uv (V, 2)` the vertices (grid corners first, then the points where the trim cuts the
    cells), `triangles (T, 3)` indices into `uv`, counter-clockwise in (u, v)."""

    uv: np.ndarray
    triangles: np.ndarray


def _loops_region(loops: list[np.ndarray]) -> shapely.Geometry:
    """The even-odd inside of closed polylines (a point inside an odd number of loops), as
    `UVTrim.contains` counts it; a self-touching loop is made valid by its linework."""
    polys = [shapely.make_valid(shapely.Polygon(lp), method="linework")
             for lp in loops if len(lp) >= 3]
    polys = [shapely.union_all(shapely.get_parts(p)[shapely.area(shapely.get_parts(p)) > 0])
             for p in polys]
    if not polys:
        return shapely.Polygon()
    return reduce(shapely.symmetric_difference, polys)


def kept_region(s: Surface) -> shapely.Geometry:
    """The part of the surface's domain its trim keeps, as a (multi)polygon in (u, v): inside
    the outer loops (the whole domain when there are none) and outside the holes."""
    (u0, u1), (v0, v1) = s.domain
    domain = shapely.box(u0, v0, u1, v1)
    if s.trim is None:
        return domain
    outer = getattr(s.trim, "outer", s.trim.loops)
    holes = getattr(s.trim, "holes", [])
    region = _loops_region(outer) if outer else domain
    if holes:
        region = shapely.difference(region, _loops_region(holes))
    return shapely.intersection(region, domain)


def trimmed_grid(s: Surface, gu: np.ndarray, gv: np.ndarray,
                 region: shapely.Geometry | None = None) -> TrimmedGrid:
    """The cells of the grid `gu x gv` (increasing parameters) cut to the surface's kept
    region (`kept_region(s)`, or `region` where the caller has it) and triangulated: whole
    cells as two triangles (a, b, c), (a, c, d) of their corners, clipped cells by a
    constrained Delaunay triangulation of their pieces. The triangles tile the kept region
    (up to the loops' own polylines) without overlap."""
    nu, nv = len(gu), len(gv)
    U, V = np.meshgrid(gu, gv, indexing="ij")
    uv = np.column_stack([U.ravel(), V.ravel()])
    idx = np.arange(nu * nv).reshape(nu, nv)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    if s.trim is None:
        return TrimmedGrid(uv, _quads(a, b, c, d))
    region = kept_region(s) if region is None else region
    shapely.prepare(region)
    lo_u, lo_v = uv[a, 0], uv[a, 1]
    hi_u, hi_v = uv[c, 0], uv[c, 1]
    cut = np.zeros(len(a), dtype=bool)
    cut[_cells_near(_border(region), gu, gv)] = True
    whole = ~cut & shapely.contains_xy(region, 0.5 * (lo_u + hi_u), 0.5 * (lo_v + hi_v))
    tri = _quads(a[whole], b[whole], c[whole], d[whole])
    if not cut.any():
        return TrimmedGrid(uv, tri)
    pieces = _clip(region, gu, gv, np.flatnonzero(cut))
    cell_area = ((hi_u - lo_u) * (hi_v - lo_v))[cut]
    corners = _clipped_triangles(pieces, cell_area)
    if len(corners) == 0:
        return TrimmedGrid(uv, tri)
    # the clipped cells' corners that are grid corners keep their index, the rest are new
    # vertices: the same point twice (a cut on an edge two cells share) is one vertex
    as_complex = np.ascontiguousarray(corners.reshape(-1, 2)).view(np.complex128).ravel()
    new, inverse = np.unique(as_complex, return_inverse=True)  # one sort, not a row sort
    new = new.view(np.float64).reshape(-1, 2)
    at = _grid_index(new, gu, gv)
    fresh = at < 0
    at[fresh] = nu * nv + np.arange(int(fresh.sum()))
    clipped = at[inverse.ravel()].reshape(-1, 3)
    return TrimmedGrid(np.concatenate([uv, new[fresh]]), np.concatenate([tri, clipped]))


def _border(region: shapely.Geometry) -> np.ndarray:
    """(E, 2, 2) the edges of the region's boundary in (u, v)."""
    coords, which = shapely.get_coordinates(
        shapely.get_parts(shapely.boundary(region)), return_index=True)
    same = which[1:] == which[:-1]
    return np.stack([coords[:-1][same], coords[1:][same]], axis=1)


def _cells_near(edges: np.ndarray, gu: np.ndarray, gv: np.ndarray) -> np.ndarray:
    """Indices (i * (nv - 1) + j) of every grid cell an edge meets, each once, and perhaps a
    few neighbours (the cells under the boxes of the edges cut into as many pieces as grid
    lines they cross)."""
    nu, nv = len(gu) - 1, len(gv) - 1
    if len(edges) == 0:
        return np.zeros(0, dtype=np.int64)
    span = np.maximum(
        np.abs(np.searchsorted(gu, edges[:, 1, 0]) - np.searchsorted(gu, edges[:, 0, 0])),
        np.abs(np.searchsorted(gv, edges[:, 1, 1]) - np.searchsorted(gv, edges[:, 0, 1])))
    k = span + 1  # pieces per edge
    edge = np.repeat(np.arange(len(edges)), k)
    first = np.repeat(np.cumsum(k) - k, k)
    t0 = (np.arange(len(edge)) - first) / k[edge]
    t1 = t0 + 1.0 / k[edge]
    p, q = edges[edge, 0], edges[edge, 1] - edges[edge, 0]
    a, b = p + t0[:, None] * q, p + t1[:, None] * q
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    i0 = np.clip(np.searchsorted(gu, lo[:, 0], "left") - 1, 0, nu - 1)
    i1 = np.clip(np.searchsorted(gu, hi[:, 0], "right") - 1, 0, nu - 1)
    j0 = np.clip(np.searchsorted(gv, lo[:, 1], "left") - 1, 0, nv - 1)
    j1 = np.clip(np.searchsorted(gv, hi[:, 1], "right") - 1, 0, nv - 1)
    out = []
    for di in range(int((i1 - i0).max()) + 1):  # a few offsets: pieces span a cell or two
        for dj in range(int((j1 - j0).max()) + 1):
            m = (i0 + di <= i1) & (j0 + dj <= j1)
            out.append((i0[m] + di) * nv + (j0[m] + dj))
    return np.unique(np.concatenate(out))


_BLOCK = 16  # cells a side of the blocks the region is first cut into


def _clip(region: shapely.Geometry, gu: np.ndarray, gv: np.ndarray,
          cells: np.ndarray) -> np.ndarray:
    """The region inside each of the grid cells `cells` (indices i * (nv - 1) + j): first cut
    to blocks of 16 x 16 cells, then each cell against its block's piece (an overlay costs the
    size of both shapes)."""
    nv = len(gv) - 1
    i, j = cells // nv, cells % nv
    bi, bj = i // _BLOCK, j // _BLOCK
    blocks, owner = np.unique(np.column_stack([bi, bj]), axis=0, return_inverse=True)
    top_u = np.minimum((blocks[:, 0] + 1) * _BLOCK, len(gu) - 1)
    top_v = np.minimum((blocks[:, 1] + 1) * _BLOCK, nv)
    near = shapely.intersection(region, shapely.box(
        gu[blocks[:, 0] * _BLOCK], gv[blocks[:, 1] * _BLOCK], gu[top_u], gv[top_v]))
    return shapely.intersection(shapely.box(gu[i], gv[j], gu[i + 1], gv[j + 1]),
                                near[owner.ravel()])


def _quads(a, b, c, d) -> np.ndarray:
    """Two counter-clockwise triangles per grid cell (a, b, c, d counter-clockwise)."""
    return np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])]).astype(
        np.int64)


def _clipped_triangles(pieces: np.ndarray, cell_area: np.ndarray) -> np.ndarray:
    """(T, 3, 2) counter-clockwise triangles of the clipped cells' pieces (constrained
    Delaunay, so the pieces' edges are kept), slivers dropped."""
    tris = shapely.constrained_delaunay_triangles(pieces)
    parts, owner = shapely.get_parts(tris, return_index=True)
    polygon = shapely.get_type_id(parts) == 3
    parts, owner = parts[polygon], owner[polygon]
    if len(parts) == 0:
        return np.zeros((0, 3, 2))
    ring = shapely.get_coordinates(shapely.get_exterior_ring(parts)).reshape(len(parts), 4, 2)
    p = ring[:, :3]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    area2 = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    keep = np.abs(area2) > 2.0 * _MIN_AREA * cell_area[owner]
    p, area2 = p[keep], area2[keep]
    flip = area2 < 0
    p[flip] = p[flip][:, ::-1]
    return p


def _grid_index(points: np.ndarray, gu: np.ndarray, gv: np.ndarray) -> np.ndarray:
    """Index of each (u, v) in the grid `gu x gv` where it is exactly a grid corner, else -1."""
    i = np.clip(np.searchsorted(gu, points[:, 0]), 0, len(gu) - 1)
    j = np.clip(np.searchsorted(gv, points[:, 1]), 0, len(gv) - 1)
    hit = (gu[i] == points[:, 0]) & (gv[j] == points[:, 1])
    return np.where(hit, i * len(gv) + j, -1)
