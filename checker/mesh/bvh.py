"""An axis-aligned bounding-box tree over the triangles of a mesh, built once per mesh and reused
for every query (numba arrays, O(T) memory).

Nodes are split at the median of the triangle centroids along the longest side of the centroids'
box (balanced: depth about log2(T / LEAF)); a leaf holds at most LEAF triangles. The triangles'
vertices are copied in the tree's order (`tri_verts (T, 3, 3)`, mm, part frame) so that a leaf
reads contiguous memory; `tri_id` maps them back to the caller's triangle indices.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

LEAF = 4
STACK = 128  # traversal stack: enough for a balanced tree of 2^60 triangles


class Tree(NamedTuple):
    """The tree as the kernels take it (mm, part frame): the nodes' boxes `node_lo, node_hi
    (M, 3)`, children `node_left, node_right (M,)` (-1 at a leaf), a leaf's triangles in tree
    order `node_start, node_count (M,)`; the triangles in tree order `tri_verts (T, 3, 3)`, their
    unit normals `tri_normal (T, 3)` and indices in the caller's mesh `tri_id (T,)`; the mesh's
    box `lo, hi (3,)`."""

    node_lo: np.ndarray
    node_hi: np.ndarray
    node_left: np.ndarray
    node_right: np.ndarray
    node_start: np.ndarray
    node_count: np.ndarray
    tri_verts: np.ndarray
    tri_normal: np.ndarray
    tri_id: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


@dataclass(frozen=True, eq=False)
class MeshIndex:
    """The AABB tree of a triangle mesh (mm, part frame). `node_lo/node_hi (M, 3)` boxes,
    `node_left/node_right (M,)` children (-1 at a leaf), `node_start/node_count (M,)` a leaf's
    triangles in tree order, `tri_verts (T, 3, 3)` the triangles in tree order, `tri_normal
    (T, 3)` their unit normals (right-hand rule; 0 for a degenerate one), `tri_id (T,)` their
    indices in `triangles`, `lo/hi (3,)` the mesh's box."""

    vertices: np.ndarray
    triangles: np.ndarray
    tri_verts: np.ndarray
    tri_normal: np.ndarray
    tri_id: np.ndarray
    node_lo: np.ndarray
    node_hi: np.ndarray
    node_left: np.ndarray
    node_right: np.ndarray
    node_start: np.ndarray
    node_count: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def build(cls, vertices: np.ndarray, triangles: np.ndarray) -> MeshIndex:
        """The tree of the mesh `vertices (V, 3)`, `triangles (T, 3)` int (T >= 1)."""
        vertices = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
        triangles = np.ascontiguousarray(triangles, dtype=np.int64).reshape(-1, 3)
        if len(triangles) == 0:
            raise ValueError("the mesh has no triangles")
        if triangles.min() < 0 or triangles.max() >= len(vertices):
            raise ValueError("triangle vertex index out of range")
        tv = np.ascontiguousarray(vertices[triangles])
        if not np.isfinite(tv).all():
            raise ValueError("non-finite vertex coordinates")
        lo, hi, left, right, start, count, order = _build(tv)
        tv = np.ascontiguousarray(tv[order])
        nrm = np.cross(tv[:, 1] - tv[:, 0], tv[:, 2] - tv[:, 0])
        ln = np.linalg.norm(nrm, axis=1)
        nrm = np.where(ln[:, None] > 0.0, nrm / np.where(ln > 0.0, ln, 1.0)[:, None], 0.0)
        return cls(vertices, triangles, tv, np.ascontiguousarray(nrm), order, lo, hi, left,
                   right, start, count, tv.reshape(-1, 3).min(0), tv.reshape(-1, 3).max(0))

    @property
    def nbytes(self) -> int:
        """Memory held by the tree (the copies of the mesh included)."""
        return sum(a.nbytes for a in (self.tri_verts, self.tri_normal, self.tri_id, self.node_lo,
                                      self.node_hi,
                                      self.node_left, self.node_right, self.node_start,
                                      self.node_count))

    def tree(self) -> Tree:
        """The tree as the kernels take it."""
        return Tree(self.node_lo, self.node_hi, self.node_left, self.node_right, self.node_start,
                    self.node_count, self.tri_verts, self.tri_normal, self.tri_id, self.lo,
                    self.hi)


@nb.njit(cache=True)
def _build(tv):
    T = tv.shape[0]
    cen = np.empty((T, 3))
    tlo = np.empty((T, 3))
    thi = np.empty((T, 3))
    for t in range(T):
        for a in range(3):
            x0, x1, x2 = tv[t, 0, a], tv[t, 1, a], tv[t, 2, a]
            tlo[t, a] = min(x0, min(x1, x2))
            thi[t, a] = max(x0, max(x1, x2))
            cen[t, a] = (x0 + x1 + x2) / 3.0
    order = np.arange(T)
    cap = 2 * T + 1   # leaves hold >= 1 triangle: at most T leaves, 2T - 1 nodes
    lo = np.empty((cap, 3))
    hi = np.empty((cap, 3))
    left = np.full(cap, -1, dtype=np.int64)
    right = np.full(cap, -1, dtype=np.int64)
    start = np.zeros(cap, dtype=np.int64)
    count = np.zeros(cap, dtype=np.int64)
    st_node = np.empty(STACK, dtype=np.int64)
    st_s = np.empty(STACK, dtype=np.int64)
    st_e = np.empty(STACK, dtype=np.int64)
    nn = 1
    sp = 0
    st_node[0], st_s[0], st_e[0] = 0, 0, T
    sp = 1
    while sp > 0:
        sp -= 1
        node, s, e = st_node[sp], st_s[sp], st_e[sp]
        clo = np.full(3, np.inf)
        chi = np.full(3, -np.inf)
        for a in range(3):
            lo[node, a] = np.inf
            hi[node, a] = -np.inf
        for k in range(s, e):
            t = order[k]
            for a in range(3):
                lo[node, a] = min(lo[node, a], tlo[t, a])
                hi[node, a] = max(hi[node, a], thi[t, a])
                clo[a] = min(clo[a], cen[t, a])
                chi[a] = max(chi[a], cen[t, a])
        if e - s <= LEAF:
            start[node], count[node] = s, e - s
            continue
        ax = 0
        for a in range(1, 3):
            if chi[a] - clo[a] > chi[ax] - clo[ax]:
                ax = a
        seg = order[s:e].copy()
        key = np.empty(e - s)
        for k in range(e - s):
            key[k] = cen[seg[k], ax]
        idx = np.argsort(key, kind="mergesort")
        for k in range(e - s):
            order[s + k] = seg[idx[k]]
        mid = (s + e) // 2
        l_node, r_node = nn, nn + 1
        nn += 2
        left[node], right[node] = l_node, r_node
        st_node[sp], st_s[sp], st_e[sp] = r_node, mid, e
        sp += 1
        st_node[sp], st_s[sp], st_e[sp] = l_node, s, mid
        sp += 1
    return (lo[:nn].copy(), hi[:nn].copy(), left[:nn].copy(), right[:nn].copy(),
            start[:nn].copy(), count[:nn].copy(), order)


@nb.njit(cache=True)
def segment_hits_box(start, along, lo, hi, node, pad) -> bool:
    """Does the segment start + s along, s in [0, 1] (3-tuples, mm), meet the box `lo[node]`,
    `hi[node]` (`Tree.node_lo`, `node_hi`) grown by `pad` on every side (a superset of the
    capsule of radius pad about the segment)? (The tree's two arrays, not the whole tree: a
    call passes each array as several words.)"""
    s0, s1 = 0.0, 1.0
    for a in range(3):
        p, d = start[a], along[a]
        bl = lo[node, a] - pad
        bh = hi[node, a] + pad
        if abs(d) < 1e-300:
            if p < bl or p > bh:
                return False
        else:
            inv = 1.0 / d
            ta = (bl - p) * inv
            tb = (bh - p) * inv
            if ta > tb:
                ta, tb = tb, ta
            if ta > s0:
                s0 = ta
            if tb < s1:
                s1 = tb
            if s0 > s1:
                return False
    return True


@nb.njit(cache=True)
def query_capsule(tree, start, along, pad, cand, stack):
    """Triangles (tree order) in leaves whose box grown by `pad` (mm) meets the segment
    start + s along, s in [0, 1] (3-tuples, mm, part frame): written into `cand` (grown when
    full; returned) and counted. `stack (STACK,)` scratch."""
    k = 0
    sp = 0
    lo, hi = tree.node_lo, tree.node_hi
    if not segment_hits_box(start, along, lo, hi, 0, pad):
        return cand, 0
    stack[0] = 0
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack[sp]
        if tree.node_left[node] < 0:
            s, c = tree.node_start[node], tree.node_count[node]
            if k + c > cand.shape[0]:
                bigger = np.empty(2 * cand.shape[0] + c, dtype=np.int64)
                bigger[:k] = cand[:k]
                cand = bigger
            for j in range(c):
                cand[k] = s + j
                k += 1
            continue
        a, b = tree.node_left[node], tree.node_right[node]
        if segment_hits_box(start, along, lo, hi, b, pad):
            stack[sp] = b
            sp += 1
        if segment_hits_box(start, along, lo, hi, a, pad):
            stack[sp] = a
            sp += 1
    return cand, k
