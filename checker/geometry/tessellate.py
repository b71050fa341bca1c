"""The part as triangles, for the exact real-tool checks (`checker.mesh`): a mesh part as it
is, and every surface of a NURBS part as the triangles of a (u, v) grid fine enough for a
chord tolerance (`sampling.surface_grid`) cut to the face's trim (`trim_cells.trimmed_grid`:
cells along the trim loops clipped, so the triangles cover the trimmed face whole). Each
triangle keeps its surface id and each vertex its (u, v), so that a point found on the
triangles can be refined on the exact surface. The deviation of the triangles from the surface
is measured (NURBS: at the edge midpoints and centroids of all triangles, which with the
tiling bounds the distance both ways, MATH.md §8.2) or estimated (a mesh:
`checker.mesh.chord.chordal_deviation`) and becomes part of the tolerance. Part frame, mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from checker.config import GeometryConfig
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import surface_grid
from checker.geometry.trim_cells import kept_region, trimmed_grid
from checker.part import Part, Surface

_CACHE: dict[tuple, PartTriangles] = {}
_CACHE_MAX = 4


@dataclass(frozen=True)
class PartTriangles:
    """`vertices (V, 3)`, `triangles (T, 3)` vertex indices, `surface (T,)` surface id of each
    triangle (-1 for a mesh part), `uv (V, 2)` parameters of each vertex on its surface (nan
    for a mesh part), `deviation (T,)` mm between each triangle and the surface it stands for
    (a mesh: the sagitta of its curved edges; NURBS: the largest measured on the part), and
    `typical` the part's deviation in one number (a mesh: the 99th percentile of its curved
    edges' sagittas; NURBS: the measured largest)."""

    vertices: np.ndarray
    triangles: np.ndarray
    surface: np.ndarray
    uv: np.ndarray
    deviation: np.ndarray
    typical: float


_REFINES = 3  # grid refinements at most to reach the deviation asked for
_MOST_GROWN = 4.0  # the budget of a surface short of the deviation grows at most this much
_MOST_CUT = 16.0  # a trim keeping less than 1/16 of the domain: the budget grows 16 times
_EVAL_BLOCK = 200_000  # surface points evaluated at once when measuring the deviation


def part_triangles(part: Part, deviation: float, cfg: GeometryConfig) -> PartTriangles:
    """The part's triangles (see the module docstring); NURBS surfaces within `deviation` mm
    (grids refined until the measured deviation is below it, or `cfg.max_samples_per_surface`
    stops them). Cached by (content hash, deviation)."""
    key = (part.content_hash, deviation, cfg.max_samples_per_surface)
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    if part.mesh is not None:
        from checker.mesh.chord import chordal_deviation, triangle_deviations

        m = part.mesh
        tri = np.ascontiguousarray(m.triangles, dtype=np.int64)
        out = PartTriangles(np.ascontiguousarray(m.vertices, dtype=float), tri,
                            np.full(len(tri), -1, dtype=np.int64),
                            np.full((len(m.vertices), 2), np.nan),
                            triangle_deviations(m.vertices, tri),
                            float(chordal_deviation(m.vertices, tri)))
    else:
        grid_cfg = cfg.model_copy(update={"max_spacing": max(cfg.max_spacing, 1e3)})
        pieces = [_within(s, deviation, grid_cfg) for s in part.surfaces]
        offsets = np.cumsum([0] + [len(p[0]) for p in pieces])
        tri = np.concatenate([p[1] + o for p, o in zip(pieces, offsets, strict=False)])
        worst = max([p[3] for p in pieces] + [0.0])
        out = PartTriangles(
            np.concatenate([p[0] for p in pieces]), tri,
            np.concatenate([np.full(len(p[1]), s.id, dtype=np.int64)
                            for p, s in zip(pieces, part.surfaces, strict=True)]),
            np.concatenate([p[2] for p in pieces]), np.full(len(tri), worst), worst)
    if len(_CACHE) >= _CACHE_MAX:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = out
    return out


def _within(s: Surface, deviation: float, cfg: GeometryConfig):
    """`_surface_triangles` of s refined until its measured deviation is below `deviation`
    (or the sample budget stops the grid). The grid's chord tolerance starts at a quarter of it
    (the triangles' interiors and the twist of the surface add to the grid lines' chord
    error); each refinement also raises the least number of grid lines a direction gets with
    the shortfall, since a twisted face (a ruled surface, whose straight direction gets the
    fewest lines) deviates by the product of the two spacings, not by their squares. Where the
    sample budget stops the grid short of the deviation, it grows once with the shortfall (at
    most 4 times)."""
    chord = 0.25 * deviation
    region = kept_region(s)  # once: every grid below is cut to it
    cfg = _kept_budget(s, region, cfg)
    out = _surface_triangles(s, region, chord, cfg)
    grown = False
    for _ in range(_REFINES):
        if out[3] <= deviation:
            break
        short = out[3] / deviation
        chord *= 0.8 / short
        fewest = int(np.ceil(cfg.min_samples_per_direction * 1.2 * short))
        cfg = cfg.model_copy(update={"min_samples_per_direction": fewest})
        finer = _surface_triangles(s, region, chord, cfg)
        if len(finer[1]) < 1.05 * len(out[1]):  # the budget stops the grid
            if grown:
                return min(out, finer, key=lambda o: o[3])
            grown = True  # once: the deviation falls as the samples grow (h^2 or hu hv)
            cfg = cfg.model_copy(update={"max_samples_per_surface": int(
                cfg.max_samples_per_surface * min(_MOST_GROWN, 1.2 * short))})
            finer = _surface_triangles(s, region, chord, cfg)
        out = finer
    return out


def _kept_budget(s: Surface, region: shapely.Geometry, cfg: GeometryConfig) -> GeometryConfig:
    """`cfg` with `max_samples_per_surface` counted over the kept region: a grid over a domain
    its trim keeps a fraction f of (`region`, its kept region) may have 1/f times as many
    corners (at most 16 times), of which about the budget are kept."""
    if s.trim is None:
        return cfg
    (u0, u1), (v0, v1) = s.domain
    kept = region.area / max((u1 - u0) * (v1 - v0), 1e-300)
    grow = min(_MOST_CUT, 1.0 / max(kept, 1e-300))
    if grow <= 1.0:
        return cfg
    return cfg.model_copy(update={"max_samples_per_surface": int(cfg.max_samples_per_surface
                                                                 * grow)})


def _surface_triangles(s: Surface, region: shapely.Geometry, chord: float,
                       cfg: GeometryConfig):
    """(vertices, triangles, uv, measured deviation) of one surface's grid cut to its kept
    `region` (`trim_cells.trimmed_grid`: whole cells inside, clipped cells along the trim
    loops)."""
    gu, gv = surface_grid(s, chord, cfg)
    uv, tri = trimmed_grid(s, gu, gv, region)
    used = np.zeros(len(uv), dtype=bool)
    used[tri] = True
    if not used.all():  # vertices of dropped cells are not evaluated
        renumber = np.cumsum(used) - 1
        uv, tri = uv[used], renumber[tri]
    pts = evaluate(s, uv[:, 0], uv[:, 1]).points if len(uv) else np.zeros((0, 3))
    # counter-clockwise in (u, v), so du x dv is their normal
    if s.flip:
        tri = tri[:, ::-1]
    return pts, tri, uv, _deviation(s, pts, uv, tri)


def _deviation(s: Surface, pts: np.ndarray, uv: np.ndarray, tri: np.ndarray) -> float:
    """Largest distance between the triangles and the surface at their edge midpoints and
    centroids (the surface evaluated at the mean parameters), mm."""
    if len(tri) == 0:
        return 0.0
    probes = [(tri[:, 0], tri[:, 1]), (tri[:, 1], tri[:, 2]), (tri[:, 0], tri[:, 2])]
    flat = [0.5 * (pts[i] + pts[j]) for i, j in probes] + [pts[tri].mean(axis=1)]
    at = [0.5 * (uv[i] + uv[j]) for i, j in probes] + [uv[tri].mean(axis=1)]
    p, q = np.concatenate(flat), np.concatenate(at)
    worst = 0.0
    for i in range(0, len(q), _EVAL_BLOCK):  # evaluated in blocks: memory bounded
        ev = evaluate(s, q[i : i + _EVAL_BLOCK, 0], q[i : i + _EVAL_BLOCK, 1])
        gap = np.linalg.norm(ev.points - p[i : i + _EVAL_BLOCK], axis=1).max()
        worst = max(worst, float(gap)) if np.isfinite(gap) else np.inf
    return worst
