"""Connected regions of the measuring mesh where a condition holds (docs/MATH.md §15.3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from checker.machined.points import SurfaceMesh


@dataclass(frozen=True)
class Region:
    """`vertices` (indices into the mesh), `area` (mm^2), `max` and area-weighted `mean` of
    the value there (mm), `at` the vertex of the largest."""

    vertices: np.ndarray
    area: float
    max: float
    mean: float
    at: int


def regions(mesh: SurfaceMesh, mask: np.ndarray, value: np.ndarray) -> list[Region]:
    """The connected sets of masked vertices (joined by the mesh's edges and where two
    surfaces' vertices coincide), largest area first, with the statistics of `value (V,)`."""
    sel = np.flatnonzero(mask)
    if sel.size == 0:
        return []
    T = mesh.triangles
    e = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]],
                        np.column_stack([np.arange(len(mesh.same)), mesh.same])])
    e = e[mask[e[:, 0]] & mask[e[:, 1]]]
    n = len(mask)
    graph = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    lab = label[sel]
    out = []
    order = np.argsort(lab, kind="stable")
    lab, idx = lab[order], sel[order]
    cuts = np.flatnonzero(np.diff(lab)) + 1
    for group in np.split(idx, cuts):
        w = mesh.area[group]
        v = value[group]
        area = float(w.sum())
        mean = float((w * v).sum() / area) if area > 0 else float(v.mean())
        k = int(np.argmax(v))
        out.append(Region(group, area, float(v[k]), mean, int(group[k])))
    out.sort(key=lambda r: -r.area)
    return out
