"""Fewer triangles for the view: vertex clustering on a uniform grid (Rossignac-Borrel). Every
vertex moves to the mean of its cell's vertices, so a surface moves by at most the cell's
diagonal; triangles that collapse are dropped. Part frame, mm."""

from __future__ import annotations

import numpy as np


def cluster(vertices: np.ndarray, triangles: np.ndarray, cell: float
            ) -> tuple[np.ndarray, np.ndarray]:
    """The mesh `vertices (V, 3)`, `triangles (T, 3)` with its vertices merged per grid cell of
    `cell` mm: (vertices (V', 3), triangles (T', 3)), collapsed and repeated triangles dropped."""
    v = np.asarray(vertices, float)
    t = np.asarray(triangles, np.int64)
    keys = np.floor((v - v.min(axis=0)) / cell).astype(np.int64)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    merged = np.zeros((len(counts), 3))
    np.add.at(merged, inverse, v)
    merged /= counts[:, None]
    nt = inverse[t]
    keep = (nt[:, 0] != nt[:, 1]) & (nt[:, 1] != nt[:, 2]) & (nt[:, 0] != nt[:, 2])
    nt = nt[keep]
    _, first = np.unique(np.sort(nt, axis=1), axis=0, return_index=True)
    nt = nt[np.sort(first)]
    used, compact = np.unique(nt, return_inverse=True)
    return merged[used], compact.reshape(-1, 3)


def weld(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mesh with its equal vertices merged (an STL's triangle soup shares its corners):
    (vertices (V', 3), triangles (T, 3)); nothing moves."""
    v, inverse = np.unique(np.asarray(vertices, float), axis=0, return_inverse=True)
    return v, inverse.ravel()[np.asarray(triangles, np.int64)]


def decimate(vertices: np.ndarray, triangles: np.ndarray, max_triangles: int
             ) -> tuple[np.ndarray, np.ndarray, float]:
    """At most `max_triangles` triangles by `cluster` with the finest cell that gets there (the
    cell grown by 1.5x from the one such a count needs on a flat sheet): (vertices, triangles,
    cell mm; 0.0 when the mesh, welded, was small enough already)."""
    v, t = weld(vertices, triangles)
    if len(t) <= max_triangles:
        return v, t, 0.0
    extent = np.ptp(v, axis=0)
    area = 2.0 * (extent[0] * extent[1] + extent[1] * extent[2] + extent[0] * extent[2])
    cell = float(np.sqrt(2.0 * area / max_triangles)) or 1e-3
    while True:
        dv, dt = cluster(v, t, cell)
        if len(dt) <= max_triangles:
            return dv, dt, cell
        cell *= 1.5
