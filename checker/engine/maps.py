"""Allowable-cutter maps (thesis ch. 4): the allowable size at an iso-parametric grid of CC
points on every surface, and at each point the largest standard cutter of the tool library
that does not exceed it. Their pictures (thesis figs 3-2, 4-2, 4-3) are drawn by
`checker.report.pictures.draw_maps`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.engine.api import allowable
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import TestPoints
from checker.part import Part
from checker.tool_library import largest_fitting


@dataclass
class SurfaceMap:
    """One surface's grid: `u (nu,)`, `v (nv,)`, `kept (nu, nv)` (inside the trim), `cc`,
    `normal (nu, nv, 3)` part frame, `size (nu, nv)` allowable (mm, inf unbounded, nan not
    kept), `standard (nu, nv)` index into the tool list (-1 none fits)."""

    id: int
    name: str
    u: np.ndarray
    v: np.ndarray
    kept: np.ndarray
    cc: np.ndarray
    normal: np.ndarray
    size: np.ndarray
    standard: np.ndarray


def allowable_maps(part: Part, tp: TestPoints, cutter, grid: tuple[int, int], tools: list,
                   axis=(0.0, 0.0, 1.0)) -> list[SurfaceMap]:
    """Maps of every surface on a `grid` (nu, nv) of (u, v); `tools` the standard cutters of
    the family, ascending by size. One batched engine call for all surfaces."""
    nu, nv = grid
    sizes = np.array([t.size for t in tools], dtype=float)
    grids, rows_cc, rows_n, rows_s, rows_uv = [], [], [], [], []
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        u, v = np.linspace(u0, u1, nu), np.linspace(v0, v1, nv)
        U, V = np.meshgrid(u, v, indexing="ij")
        kept = np.ones(U.shape, bool) if s.trim is None else \
            np.asarray(s.trim.contains(U.ravel(), V.ravel()), bool).reshape(U.shape)
        ev = evaluate(s, U.ravel(), V.ravel())
        grids.append((s, u, v, kept, ev.points.reshape(nu, nv, 3), ev.normals.reshape(nu, nv, 3)))
        k = kept.ravel()
        rows_cc.append(ev.points[k])
        rows_n.append(ev.normals[k])
        rows_s.append(np.full(int(k.sum()), s.id))
        rows_uv.append(np.column_stack([U.ravel()[k], V.ravel()[k]]))
    res = allowable(tp, part, cutter, np.concatenate(rows_cc), np.concatenate(rows_n), axis,
                    cc_surface=np.concatenate(rows_s), cc_uv=np.concatenate(rows_uv))
    out, at = [], 0
    for s, u, v, kept, cc, nrm in grids:
        k = int(kept.sum())
        size = np.full(kept.shape, np.nan)
        size[kept] = res.size[at:at + k]
        at += k
        std = largest_fitting(sizes, size)  # nan where not kept: -1
        out.append(SurfaceMap(s.id, s.name, u, v, kept, cc, nrm, size, std))
    return out


def maps_document(maps: list[SurfaceMap], cutter, tools: list) -> dict:
    """JSON view: the cutter, the tools, and per surface the grid with allowable (null =
    unbounded) and the standard cutter name (null = none fits) per kept point."""
    surfaces = []
    for m in maps:
        pts = []
        for i, j in zip(*np.nonzero(m.kept), strict=True):
            s = float(m.size[i, j])
            pts.append({"u": float(m.u[i]), "v": float(m.v[j]),
                        "cc": [round(float(x), 6) for x in m.cc[i, j]],
                        "normal": [round(float(x), 9) for x in m.normal[i, j]],
                        "allowable": round(s, 6) if np.isfinite(s) else None,
                        "standard": (tools[m.standard[i, j]].name if m.standard[i, j] >= 0
                                     else None)})
        surfaces.append({"id": m.id, "name": m.name, "grid": [len(m.u), len(m.v)], "points": pts})
    return {"cutter": cutter.to_apt(), "kind": cutter.kind,
            "tools": [{"name": t.name, "size": t.size} for t in tools], "surfaces": surfaces}
