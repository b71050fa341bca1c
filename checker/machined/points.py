"""The points the machined part is measured at: the part's triangles split (longest edge first)
until no edge is longer than a spacing, their vertices given outward unit normals (per surface
of a NURBS part, across a mesh part) (docs/MATH.md §15.1). Part frame, mm."""

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


_KEY = np.int64(1) << 31  # edge key: lo * _KEY + hi (vertex indices below 2^31)


def _subdivided(V: np.ndarray, T: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray,
                                                                       np.ndarray]:
    """(points, triangles, parent triangle of each triangle) of every triangle split at the
    midpoint of its longest edge until no edge is longer than `spacing` (a thin triangle gets
    points along its length only). An edge's midpoint is made once, whichever triangle
    splits it first, and found again by the others."""
    pts = [V]
    n_pts = len(V)
    tri = T.copy()
    parent = np.arange(len(T))
    done_tri, done_parent = [], []
    known = np.zeros(0, np.int64)                    # sorted edge keys split so far
    known_mid = np.zeros(0, np.int64)                # their midpoints
    while True:
        P = np.concatenate(pts) if len(pts) > 1 else pts[0]
        pts = [P]
        e = np.stack([P[tri[:, 1]] - P[tri[:, 0]], P[tri[:, 2]] - P[tri[:, 1]],
                      P[tri[:, 0]] - P[tri[:, 2]]], axis=1)
        length = np.einsum("tkc,tkc->tk", e, e)
        k = np.argmax(length, axis=1)
        split = length[np.arange(len(tri)), k] > spacing * spacing
        done_tri.append(tri[~split])
        done_parent.append(parent[~split])
        if not split.any():
            return P, np.concatenate(done_tri), np.concatenate(done_parent)
        t = tri[split]
        k = k[split]
        r = np.arange(len(t))
        a, b, c = t[r, k], t[r, (k + 1) % 3], t[r, (k + 2) % 3]   # longest edge a-b
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        key = lo * _KEY + hi
        at = np.searchsorted(known, key)
        found = at < len(known)
        found[found] = known[at[found]] == key[found]
        mid = np.empty(len(t), np.int64)
        mid[found] = known_mid[at[found]]
        new_keys, first, inv = np.unique(key[~found], return_index=True, return_inverse=True)
        new_ids = n_pts + np.arange(len(new_keys))
        mid[~found] = new_ids[inv.reshape(-1)]
        nlo, nhi = lo[~found][first], hi[~found][first]
        pts.append(0.5 * (P[nlo] + P[nhi]))
        n_pts += len(new_keys)
        order = np.argsort(np.concatenate([known, new_keys]), kind="stable")
        known = np.concatenate([known, new_keys])[order]
        known_mid = np.concatenate([known_mid, new_ids])[order]
        tri = np.concatenate([np.column_stack([a, mid, c]), np.column_stack([mid, b, c])])
        parent = np.concatenate([parent[split], parent[split]])


def _same_place(points: np.ndarray) -> np.ndarray:
    """(V,) the least index of a point equal within _WELD to each point."""
    q = np.round(points / _WELD).astype(np.int64)
    order = np.lexsort((q[:, 2], q[:, 1], q[:, 0]))
    s = q[order]
    new = np.ones(len(s), bool)
    new[1:] = np.any(s[1:] != s[:-1], axis=1)
    group = np.cumsum(new) - 1
    first = np.flatnonzero(new)                          # the least index: order is stable
    out = np.empty(len(points), np.int64)
    out[order] = order[first][group]
    return out


def surface_mesh(vertices: np.ndarray, triangles: np.ndarray, surface: np.ndarray,
                 spacing: float) -> SurfaceMesh:
    """The measuring mesh of a part's triangles `vertices (V, 3)`, `triangles (T, 3)`,
    `surface (T,)` (`checker.geometry.tessellate.PartTriangles`; -1: a mesh part) with edges
    at most `spacing` mm."""
    V = np.asarray(vertices, np.float64)
    T = np.asarray(triangles, np.int64)
    if not (spacing > 0.0 and math.isfinite(spacing)):
        raise ValueError(f"spacing must be a positive number of mm, found {spacing}")
    verts, tris, parent = _subdivided(V, T, spacing)
    surf = np.full(len(verts), -1, np.int64)
    surf[tris.reshape(-1)] = np.repeat(np.asarray(surface, np.int64)[parent], 3)
    face = np.cross(verts[tris[:, 1]] - verts[tris[:, 0]], verts[tris[:, 2]] - verts[tris[:, 0]])
    area2 = np.linalg.norm(face, axis=1)
    corner = tris.reshape(-1)                            # area-weighted face normals
    normals = np.column_stack([np.bincount(corner, np.repeat(face[:, k], 3), len(verts))
                               for k in range(3)])
    length = np.linalg.norm(normals, axis=1)
    normals = normals / np.where(length > 0, length, 1.0)[:, None]
    area = np.bincount(corner, np.repeat(area2 / 6.0, 3), len(verts))
    return SurfaceMesh(verts, normals, tris, area, surf, _same_place(verts))
