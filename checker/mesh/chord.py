"""How far a triangle mesh departs from the smooth surface it tessellates (its chordal deviation).

A circle of radius rho cut into chords of length L: each chord subtends the angle theta = 2
arcsin(L / (2 rho)) ~ L / rho at the centre, and two neighbouring chords turn by that same angle
theta (their normals differ by theta). The chord's sagitta (its largest distance from the arc) is
rho (1 - cos(theta / 2)); with rho = L / (2 sin(theta / 2)) that is exactly
(L / 2) tan(theta / 4) ~ L theta / 8 for small theta. So an edge shared by two triangles whose
normals turn by a small theta, with L the width of the triangles across that edge (each one's
height over the edge, i.e. 2 area / edge length, averaged over the two), shows a sagitta of
about (L / 2) tan(theta / 4).

Only turns below `max_turn` (20 degrees) count as tessellated curvature; larger turns are real
edges of the part (a cube's edges, a chamfer), and edges with no turn (planar faces, the
diagonals of planar quads) say nothing about curvature and are left out. The value returned is a
high percentile (the 99th) of the sagittas of the curved edges, not their maximum: a handful of
sliver triangles or badly rounded normals would decide a maximum, while the 99th percentile still
is the deviation of the coarsest tessellated region of any size (1 % of the curved edges). A mesh
with only planar faces returns 0.
"""

from __future__ import annotations

import math

import numpy as np


def _curved_edges(vertices: np.ndarray, triangles: np.ndarray, max_turn: float):
    """(sagitta (E,), first triangle (E,), second triangle (E,)) of the edges shared by exactly
    two triangles whose normals turn by more than 1e-9 rad and less than `max_turn` (rad);
    triangle indices into `triangles`."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    p0, p1, p2 = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    cr = np.cross(p1 - p0, p2 - p0)
    area2 = np.linalg.norm(cr, axis=1)
    keep = np.flatnonzero(area2 > 0.0)
    t, cr, area2 = t[keep], cr[keep], area2[keep]
    if len(t) < 2:
        z = np.zeros(0, dtype=np.int64)
        return np.zeros(0), z, z
    nrm = cr / area2[:, None]
    # directed edges a -> b of each triangle, keyed by the unordered pair
    a = t[:, [0, 1, 2]].ravel()
    b = t[:, [1, 2, 0]].ravel()
    tri = np.repeat(np.arange(len(t)), 3)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * (int(v.shape[0]) + 1) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    uniq, start, count = np.unique(ks, return_index=True, return_counts=True)
    pair = count == 2
    i1 = order[start[pair]]
    i2 = order[start[pair] + 1]
    t1, t2 = tri[i1], tri[i2]
    n1, n2 = nrm[t1], nrm[t2]
    # a consistently oriented pair runs the edge in opposite directions; else flip one normal
    same_dir = a[i1] == a[i2]
    n2 = np.where(same_dir[:, None], -n2, n2)
    cosang = np.einsum("ij,ij->i", n1, n2)
    sinang = np.linalg.norm(np.cross(n1, n2), axis=1)
    theta = np.arctan2(sinang, cosang)
    elen = np.linalg.norm(v[hi[i1]] - v[lo[i1]], axis=1)
    width = 0.5 * (area2[t1] + area2[t2]) / elen       # the mean height over the edge
    curved = (theta > 1e-9) & (theta < max_turn)
    sag = 0.5 * width[curved] * np.tan(0.25 * theta[curved])
    return sag, keep[t1[curved]], keep[t2[curved]]


def edge_sagittas(vertices: np.ndarray, triangles: np.ndarray,
                  max_turn: float = math.radians(20.0)) -> np.ndarray:
    """Sagitta estimate (mm) of every edge shared by exactly two triangles whose normals turn by
    more than 1e-9 rad and less than `max_turn` (rad)."""
    return _curved_edges(vertices, triangles, max_turn)[0]


def triangle_deviations(vertices: np.ndarray, triangles: np.ndarray,
                        max_turn: float = math.radians(20.0)) -> np.ndarray:
    """(T,) mm: per triangle, the largest sagitta of the curved edges around its vertices (0
    in a planar region): how far the surface it stands for may lie from it. Through the
    vertices, a planar face's triangles along a tessellated curve (a boss's top at its wall)
    get the curve's deviation too: a tool touching that rim touches the curve."""
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    sag, t1, t2 = _curved_edges(vertices, t, max_turn)
    at_vertex = np.zeros(len(np.asarray(vertices).reshape(-1, 3)))
    for tri in (t1, t2):
        for k in range(3):
            np.maximum.at(at_vertex, t[tri, k], sag)
    return at_vertex[t].max(axis=1) if len(t) else np.zeros(0)


def chordal_deviation(vertices: np.ndarray, triangles: np.ndarray,
                      percentile: float = 99.0) -> float:
    """Estimated chordal deviation (mm) of the mesh `vertices (V, 3)`, `triangles (T, 3)`: the
    `percentile` of the sagittas of its tessellated-curvature edges (module docstring); 0 when
    it has none (only planar faces)."""
    s = edge_sagittas(vertices, triangles)
    if s.size == 0:
        return 0.0
    return float(np.percentile(s, percentile))
