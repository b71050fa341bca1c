"""The points the machined part is measured at: the part's triangles split (longest edge first)
until no edge is longer than a spacing, their vertices given outward unit normals (per surface
of a NURBS part, across a mesh part) (docs/MATH.md §15.1). Part frame, mm."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_WELD = 1e-6  # mm: vertices this close are one
CREASE_DEG = 20.0  # faces meeting at a larger angle do not share a vertex normal


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


def _meets(P: np.ndarray, tri: np.ndarray, box: np.ndarray | None) -> np.ndarray:
    """(T,) bool: the triangles whose bounding box meets the x, y `box (2, 2)` (None: all)."""
    if box is None:
        return np.ones(len(tri), bool)
    c = P[tri]
    lo, hi = c.min(axis=1), c.max(axis=1)
    return ((hi[:, 0] >= box[0, 0]) & (lo[:, 0] <= box[1, 0]) & (hi[:, 1] >= box[0, 1])
            & (lo[:, 1] <= box[1, 1]))


def _subdivided(V: np.ndarray, T: np.ndarray, spacing: float,
                box: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points, triangles, parent triangle of each triangle) of every triangle split at the
    midpoint of its longest edge until no edge is longer than `spacing` (a thin triangle gets
    points along its length only), keeping only the pieces that meet the x, y `box`. An
    edge's midpoint is made once, whichever triangle splits it first, and found again by the
    others."""
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
        inside = _meets(P, tri, box)
        tri, parent = tri[inside], parent[inside]
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


def _creases_split(V: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices, triangles, original vertex of each) with every vertex split per smoothing
    group: a triangle's corner takes the normal of the faces around its vertex within
    CREASE_DEG of its own face, and corners of one vertex with the same normal share a new
    vertex. A point on a sharp edge is then measured along each face's normal, not along
    their mean (which would cut across the corner)."""
    face = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    norm = np.linalg.norm(face, axis=1)
    unit = face / np.where(norm > 0, norm, 1.0)[:, None]
    corner_v = T.reshape(-1)
    corner_t = np.repeat(np.arange(len(T)), 3)
    order = np.argsort(corner_v, kind="stable")
    sv = corner_v[order]
    start = np.flatnonzero(np.r_[True, sv[1:] != sv[:-1]])
    size = np.diff(np.r_[start, len(sv)])
    group_size = np.repeat(size, size)                   # per sorted corner
    group_start = np.repeat(start, size)
    i = np.repeat(np.arange(len(sv)), group_size)        # every pair of corners of a vertex
    offset = np.arange(len(i)) - np.repeat(np.cumsum(group_size) - group_size, group_size)
    j = group_start[i] + offset
    ti, tj = corner_t[order[i]], corner_t[order[j]]
    near = np.einsum("ij,ij->i", unit[ti], unit[tj]) >= np.cos(np.radians(CREASE_DEG))
    normal = np.column_stack([np.bincount(i[near], face[tj[near], k], len(sv))
                              for k in range(3)])
    length = np.linalg.norm(normal, axis=1)
    normal = normal / np.where(length > 0, length, 1.0)[:, None]
    key = np.column_stack([sv, np.round(normal * 1e6).astype(np.int64)])
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    new_of_corner = np.empty(len(corner_v), np.int64)
    new_of_corner[order] = inv.reshape(-1)
    original = sv[first]
    return V[original], new_of_corner.reshape(-1, 3), original


def surface_mesh(vertices: np.ndarray, triangles: np.ndarray, surface: np.ndarray,
                 spacing: float, box: np.ndarray | None = None) -> SurfaceMesh:
    """The measuring mesh of a part's triangles `vertices (V, 3)`, `triangles (T, 3)`,
    `surface (T,)` (`checker.geometry.tessellate.PartTriangles`; -1: a mesh part) with edges
    at most `spacing` mm, cropped to the triangles that meet the x, y `box (2, 2)` (mm)."""
    V = np.asarray(vertices, np.float64)
    T = np.asarray(triangles, np.int64)
    if not (spacing > 0.0 and math.isfinite(spacing)):
        raise ValueError(f"spacing must be a positive number of mm, found {spacing}")
    V, T, _ = _creases_split(V, T)
    verts, tris, parent = _subdivided(V, T, spacing, box)
    used = np.zeros(len(verts), bool)
    used[tris.reshape(-1)] = True
    renum = np.cumsum(used) - 1
    verts, tris = verts[used], renum[tris]
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
