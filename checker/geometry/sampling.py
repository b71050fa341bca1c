"""Test points for the allowable-cutter search: every surface of a part sampled densely enough
for the sag tolerance and the spacing limit in config, trimmed-away regions left out, each point
with its (surface, u, v), in one k-d tree. Cached in memory by (content hash, settings)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from checker.config import GeometryConfig, default_config
from checker.geometry.evaluate import evaluate
from checker.geometry.nearest import PointTree
from checker.part import MeshPart, Part, Surface

_PROBES_PER_SPAN = 4
_PROBE_BLOCK = 100_000  # surface points evaluated at once while probing derivatives
_CACHE: dict[tuple, TestPoints] = {}
_CACHE_MAX = 8


@dataclass
class TestPoints:
    """M test points in mm in the part frame: `points (M, 3)`, unit `normals (M, 3)` (out of the
    material), `surface (M,) int32` (-1 for mesh parts), `uv (M, 2)` (nan for mesh parts),
    `spacing (M,)` mm: the diagonal of the local sample cell, so every kept surface point lies
    within spacing / 2 (plus the sag tolerance) of a test point; `tree` a k-d tree over points."""

    __test__ = False  # not a pytest class

    points: np.ndarray
    normals: np.ndarray
    surface: np.ndarray
    uv: np.ndarray
    spacing: np.ndarray
    tree: PointTree
    caches: dict[str, dict] = field(default_factory=dict, init=False, repr=False, compare=False)

    def cache(self, owner: str) -> dict:
        """A dict of derived data that lives and dies with these test points, one per `owner`
        (the module that keeps it)."""
        return self.caches.setdefault(owner, {})


def sample_part(
    part: Part, sag: float | None = None, geometry: GeometryConfig | None = None
) -> TestPoints:
    """Test points of the whole part; `sag` (mm) overrides the config's sag tolerance."""
    cfg = geometry or default_config().geometry
    sag = float(sag if sag is not None else cfg.sag_tolerance)
    if sag <= 0:
        raise ValueError(f"sag tolerance must be positive, got {sag}")
    key = (
        part.content_hash,
        sag,
        cfg.max_spacing,
        cfg.max_samples_per_surface,
        cfg.min_samples_per_direction,
    )
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    if part.mesh is not None:
        pts, nrm, sid, uv, spc = _sample_mesh(part.mesh)
    else:
        chunks = [_sample_surface(s, sag, cfg) for s in part.surfaces]
        pts, nrm, sid, uv, spc = (np.concatenate([c[i] for c in chunks]) for i in range(5))
    tp = TestPoints(pts, nrm, sid.astype(np.int32), uv, spc, PointTree(pts))
    if len(_CACHE) >= _CACHE_MAX:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = tp
    return tp


def _span_breaks(knots: np.ndarray, degree: int) -> np.ndarray:
    """Distinct knot values inside the domain (span boundaries)."""
    return np.unique(knots[degree : len(knots) - degree])


def _probe(breaks: np.ndarray) -> np.ndarray:
    s = np.linspace(0.0, 1.0, _PROBES_PER_SPAN + 1)
    return (breaks[:-1, None] + s * np.diff(breaks)[:, None]).ravel()


def _counts(breaks, d1max, d2max, sag, max_spacing, cap) -> np.ndarray:
    """Samples per span for one direction: sag h^2 |S''| / 8 <= sag and h |S'| <= max_spacing,
    from the largest derivatives probed in each span; each in [1, cap] (derivatives that
    overflow ask for `cap`)."""
    length = np.diff(breaks)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        need = np.maximum(length * np.sqrt(d2max / (8.0 * sag)), length * d1max / max_spacing)
    return np.clip(np.nan_to_num(need, nan=cap, posinf=cap), 1.0, cap)


def _probe_maxima(s: Surface, pu: np.ndarray, pv: np.ndarray):
    """Largest |S_u|, |S_uu| over v at each u-probe and |S_v|, |S_vv| over u at each v-probe,
    evaluated in blocks of at most _PROBE_BLOCK points (memory bounded, not the probe grid)."""
    d1u, d2u = np.zeros(len(pu)), np.zeros(len(pu))
    d1v, d2v = np.zeros(len(pv)), np.zeros(len(pv))
    rows = max(1, _PROBE_BLOCK // len(pv))
    for i in range(0, len(pu), rows):
        U, V = np.meshgrid(pu[i : i + rows], pv, indexing="ij")
        ev = evaluate(s, U.ravel(), V.ravel(), order=2)
        n = {k: np.linalg.norm(getattr(ev, k), axis=1).reshape(U.shape)
             for k in ("du", "duu", "dv", "dvv")}
        d1u[i : i + rows], d2u[i : i + rows] = n["du"].max(axis=1), n["duu"].max(axis=1)
        d1v, d2v = np.maximum(d1v, n["dv"].max(axis=0)), np.maximum(d2v, n["dvv"].max(axis=0))
    return d1u, d2u, d1v, d2v


def _span_max(values: np.ndarray, nspan: int) -> np.ndarray:
    """Per span, the largest of its _PROBES_PER_SPAN + 1 probe values."""
    return values.reshape(nspan, _PROBES_PER_SPAN + 1).max(axis=1)


def _grid(breaks: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Parameters uniform within each span, `counts` intervals per span, both ends included."""
    n = counts.astype(np.int64)
    span = np.repeat(np.arange(len(n)), n)
    frac = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / n[span]
    return np.append(breaks[span] + frac * np.diff(breaks)[span], breaks[-1])


def surface_grid(s: Surface, sag: float, cfg: GeometryConfig) -> tuple[np.ndarray, np.ndarray]:
    """Parameter grids (gu, gv) of surface s, uniform within each knot span and fine enough
    that the grid lines stay within `sag` mm of the surface (h^2 |S''| / 8 <= sag, from probes
    of the second derivatives) and `cfg.max_spacing` apart, at most
    `cfg.max_samples_per_surface` points (or one interval per knot span when the spans are
    more: the grid never outgrows the part's own poles)."""
    bu = _span_breaks(s.knots_u, s.degree_u)
    bv = _span_breaks(s.knots_v, s.degree_v)
    d1u, d2u, d1v, d2v = _probe_maxima(s, _probe(bu), _probe(bv))
    cap = float(cfg.max_samples_per_surface)
    nu, nv = len(bu) - 1, len(bv) - 1
    cu = _counts(bu, _span_max(d1u, nu), _span_max(d2u, nu), sag, cfg.max_spacing, cap)
    cv = _counts(bv, _span_max(d1v, nv), _span_max(d2v, nv), sag, cfg.max_spacing, cap)
    nmin = cfg.min_samples_per_direction
    cu *= max(1.0, nmin / cu.sum())
    cv *= max(1.0, nmin / cv.sum())
    total = (cu.sum() + 1) * (cv.sum() + 1)
    if total > cap:
        f = np.sqrt(cap / total)
        cu, cv = np.maximum(cu * f, 1.0), np.maximum(cv * f, 1.0)
    return _grid(bu, np.ceil(cu)), _grid(bv, np.ceil(cv))


def _sample_surface(s: Surface, sag: float, cfg: GeometryConfig):
    gu, gv = surface_grid(s, sag, cfg)
    hu, hv = _local_step(gu), _local_step(gv)
    U, V = np.meshgrid(gu, gv, indexing="ij")
    HU, HV = np.meshgrid(hu, hv, indexing="ij")
    u, v, hu, hv = U.ravel(), V.ravel(), HU.ravel(), HV.ravel()
    if s.trim is not None:
        keep = s.trim.contains(u, v)
        u, v, hu, hv = u[keep], v[keep], hu[keep], hv[keep]
    ev = evaluate(s, u, v)
    spacing = np.hypot(np.linalg.norm(ev.du, axis=1) * hu, np.linalg.norm(ev.dv, axis=1) * hv)
    pts, nrm, uv, spc = ev.points, ev.normals, np.column_stack([u, v]), spacing
    if s.trim is not None:
        step = float(np.median(spacing)) if spacing.size else cfg.max_spacing
        bpts, bnrm, buv = _boundary(s, step, cfg.max_samples_per_surface)
        pts, nrm, uv = (
            np.concatenate([pts, bpts]),
            np.concatenate([nrm, bnrm]),
            np.concatenate([uv, buv]),
        )
        spc = np.concatenate([spc, np.full(len(bpts), step)])
    return pts, nrm, np.full(len(pts), s.id, dtype=np.int32), uv, spc


def _local_step(g: np.ndarray) -> np.ndarray:
    """Per grid parameter, the larger of its two neighbouring intervals."""
    d = np.diff(g)
    return np.maximum(np.append(d, d[-1]), np.insert(d, 0, d[0]))


def _boundary(s: Surface, step: float, max_points: int):
    """Samples along the trim loops, about `step` mm apart (the loop vertices are kept too;
    farther apart when that would be more than `max_points` beside the vertices)."""
    (u0, u1), (v0, v1) = s.domain
    loops = [np.vstack([lp, lp[:1]]) for lp in s.trim.loops if len(lp) >= 2]
    if not loops:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2))
    segs = [np.linalg.norm(np.diff(evaluate(s, lp[:, 0], lp[:, 1]).points, axis=0), axis=1)
            for lp in loops]
    length = float(sum(seg.sum() for seg in segs))
    step = max(step, length / max_points, 1e-9)  # at most about max_points samples
    uv = []
    for lp, seg in zip(loops, segs, strict=True):  # each loop is resampled as a whole
        k = np.maximum(np.ceil(seg / step), 1).astype(np.int64)
        idx = np.repeat(np.arange(len(seg)), k)
        t = (np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)) / k[idx]
        uv.append(lp[idx] + t[:, None] * (lp[idx + 1] - lp[idx]))
    uv = np.concatenate(uv)
    uv[:, 0] = np.clip(uv[:, 0], u0, u1)
    uv[:, 1] = np.clip(uv[:, 1], v0, v1)
    ev = evaluate(s, uv[:, 0], uv[:, 1])
    return ev.points, ev.normals, uv


def _sample_mesh(mesh: MeshPart):
    """A mesh part's test points: its vertices with area-weighted normals (the exact checks on
    meshes use the triangles themselves, `checker.mesh`; memory stays in O(triangles)).
    `spacing` is the longest edge at each vertex."""
    V, T, N = mesh.vertices, mesh.triangles, mesh.normals
    tri = V[T]
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    vn = np.zeros_like(V)
    np.add.at(vn, T.ravel(), np.repeat(N * area[:, None], 3, axis=0))
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    spc = np.zeros(len(V))
    np.maximum.at(spc, T.ravel(), np.repeat(edges, 3))
    m = len(V)
    return V, vn, np.full(m, -1, dtype=np.int32), np.full((m, 2), np.nan), spc
