"""The points the machined part is measured at: the part's triangles subdivided so no edge is
longer than a spacing, their vertices welded (per surface of a NURBS part, across a mesh part)
and given outward unit normals (docs/MATH.md §15.1). Part frame, mm."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_WELD = 1e-6  # mm: vertices this close are one


@dataclass(frozen=True)
class SurfaceMesh:
    """`vertices (V, 3)`, unit outward `normals (V, 3)`, `triangles (T, 3)`, `area (V,)` the
    part's area each vertex stands for (a third of its triangles', mm^2), `surface (V,)` the
    part's surface id (-1: a mesh part), `same (V,)` the index of a vertex at the same place
    (vertices of two surfaces meeting at an edge share it)."""

    vertices: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    area: np.ndarray
    surface: np.ndarray
    same: np.ndarray


def _subdivided(V: np.ndarray, T: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray,
                                                                       np.ndarray]:
    """(points, triangles, parent triangle of each point) of every triangle cut into k^2 by
    k = ceil(longest edge / spacing) along its edges (points not yet welded)."""
    a, b, c = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                      np.linalg.norm(a - c, axis=1)], axis=0)
    k_of = np.clip(np.ceil(longest / spacing), 1, 64).astype(np.int64)
    pts, tris, parent = [], [], []
    base = 0
    for k in np.unique(k_of):
        sel = np.flatnonzero(k_of == k)
        ii, jj = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = ii + jj <= k
        ii, jj = ii[keep], jj[keep]                      # barycentric grid, (P,)
        P = len(ii)
        at = -np.ones((k + 1, k + 1), np.int64)
        at[ii, jj] = np.arange(P)
        up = [(at[i, j], at[i + 1, j], at[i, j + 1]) for i in range(k) for j in range(k - i)]
        down = [(at[i + 1, j], at[i + 1, j + 1], at[i, j + 1])
                for i in range(k) for j in range(k - i - 1)]
        local = np.array(up + down, np.int64)            # counter-clockwise like (a, b, c)
        u, w = ii / k, jj / k
        p = (a[sel, None, :] * (1 - u - w)[None, :, None] + b[sel, None, :] * u[None, :, None]
             + c[sel, None, :] * w[None, :, None])
        pts.append(p.reshape(-1, 3))
        tris.append((local[None, :, :] + (base + P * np.arange(len(sel)))[:, None, None])
                    .reshape(-1, 3))
        parent.append(np.repeat(sel, P))
        base += P * len(sel)
    return np.concatenate(pts), np.concatenate(tris), np.concatenate(parent)


def _weld(points: np.ndarray, key_extra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(first index of each group, group of each point) of points equal within _WELD that
    share `key_extra`."""
    q = np.round(points / _WELD).astype(np.int64)
    key = np.column_stack([q, key_extra])
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return first, inverse.reshape(-1)


def surface_mesh(vertices: np.ndarray, triangles: np.ndarray, surface: np.ndarray,
                 spacing: float) -> SurfaceMesh:
    """The measuring mesh of a part's triangles `vertices (V, 3)`, `triangles (T, 3)`,
    `surface (T,)` (`checker.geometry.tessellate.PartTriangles`; -1: a mesh part) with edges
    at most `spacing` mm (a triangle is cut in at most 64 x 64)."""
    V = np.asarray(vertices, np.float64)
    T = np.asarray(triangles, np.int64)
    if not (spacing > 0.0 and math.isfinite(spacing)):
        raise ValueError(f"spacing must be a positive number of mm, found {spacing}")
    pts, tris, parent = _subdivided(V, T, spacing)
    surf_of_point = np.asarray(surface, np.int64)[parent]
    first, group = _weld(pts, surf_of_point)
    verts = pts[first]
    tris = group[tris]
    surf = surf_of_point[first]
    ok = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
    tris = tris[ok]
    face = np.cross(verts[tris[:, 1]] - verts[tris[:, 0]], verts[tris[:, 2]] - verts[tris[:, 0]])
    area2 = np.linalg.norm(face, axis=1)
    normals = np.zeros_like(verts)
    for c in range(3):                                   # area-weighted face normals
        np.add.at(normals, tris[:, c], face)
    length = np.linalg.norm(normals, axis=1)
    normals = normals / np.where(length > 0, length, 1.0)[:, None]
    area = np.zeros(len(verts))
    for c in range(3):
        np.add.at(area, tris[:, c], area2 / 6.0)
    first_any, group_any = _weld(verts, np.zeros(len(verts), np.int64))
    return SurfaceMesh(verts, normals, tris, area, surf, first_any[group_any])
