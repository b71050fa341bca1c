"""Exact test parts for the engine tests, built with geomdl (rational NURBS) and converted to
`checker.part.Surface`: a concave spherical bowl, a concave cylindrical groove, a tilted floor
beside a vertical wall, and a two-surface example built like thesis Fig. 3-1."""

from __future__ import annotations

import numpy as np
from geomdl import NURBS

from checker.geometry.evaluate import evaluate
from checker.part import Part, Surface

_S = np.sqrt(0.5)
# full circle, degree 2: (x, y, w)
_CIRCLE = [(1, 0, 1), (1, 1, _S), (0, 1, 1), (-1, 1, _S), (-1, 0, 1), (-1, -1, _S), (0, -1, 1),
           (1, -1, _S), (1, 0, 1)]
_CIRCLE_KV = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]


def geomdl_surface(poles: np.ndarray, weights: np.ndarray, deg: tuple[int, int],
                   kv_u, kv_v) -> NURBS.Surface:
    """A geomdl rational surface from Cartesian poles (nu, nv, 3) and weights (nu, nv)."""
    nu, nv = weights.shape
    s = NURBS.Surface()
    s.degree_u, s.degree_v = deg
    s.ctrlpts_size_u, s.ctrlpts_size_v = nu, nv
    pw = np.concatenate([poles * weights[..., None], weights[..., None]], axis=2)
    s.ctrlptsw = pw.reshape(-1, 4).tolist()
    s.knotvector_u, s.knotvector_v = list(kv_u), list(kv_v)
    return s


def to_surface(g: NURBS.Surface, sid: int, flip: bool = False, name: str = "s") -> Surface:
    """checker Surface with the same poles, weights and knots as the geomdl surface."""
    nu, nv = g.ctrlpts_size_u, g.ctrlpts_size_v
    surf = Surface(id=sid, name=name, kind="nurbs", degree_u=g.degree_u, degree_v=g.degree_v,
                   knots_u=np.array(g.knotvector_u), knots_v=np.array(g.knotvector_v),
                   ctrlpts=np.array(g.ctrlpts).reshape(nu, nv, 3),
                   weights=np.array(g.weights).reshape(nu, nv), flip=flip)
    return surf


def facing_up(surf: Surface) -> Surface:
    """Flip the surface's normal so that it points up (+z) at the middle of its domain."""
    (u0, u1), (v0, v1) = surf.domain
    if evaluate(surf, [0.5 * (u0 + u1)], [0.5 * (v0 + v1)]).normals[0, 2] < 0:
        surf.flip = not surf.flip
    return surf


def bowl(rho: float) -> tuple[Part, NURBS.Surface]:
    """Lower hemisphere of radius rho centred at (0, 0, rho): bottom at the origin, normals
    towards the centre (concave, facing the tool). u around +z, v from the bottom to the rim."""
    arc = [(0, -1, 1), (1, -1, _S), (1, 0, 1)]  # (radial, height, w) bottom -> equator
    P = np.array([[(x * a, y * a, h) for a, h, _ in arc] for x, y, _ in _CIRCLE], dtype=float)
    W = np.array([[wc * wa for _, _, wa in arc] for _, _, wc in _CIRCLE], dtype=float)
    g = geomdl_surface(rho * P + [0, 0, rho], W, (2, 2), _CIRCLE_KV, [0, 0, 0, 1, 1, 1])
    return Part([facing_up(to_surface(g, 0, name="bowl"))]), g


def groove(rho: float, length: float) -> tuple[Part, NURBS.Surface]:
    """Lower half of a cylinder of radius rho about the line y = 0, z = rho, from x = -length/2
    to length/2: bottom along the x axis, normals towards the axis (concave)."""
    half = [(-1, 0, 1), (-1, -1, _S), (0, -1, 1), (1, -1, _S), (1, 0, 1)]  # (y, z, w)
    xs = [-length / 2, length / 2]
    P = np.array([[(x, y * rho, z * rho + rho) for x in xs] for y, z, _ in half], dtype=float)
    W = np.array([[w, w] for _, _, w in half], dtype=float)
    g = geomdl_surface(P, W, (2, 1), [0, 0, 0, 0.5, 0.5, 1, 1, 1], [0, 0, 1, 1])
    return Part([facing_up(to_surface(g, 0, name="groove"))]), g


def _bilinear(corner, eu, ev, sid: int, name: str) -> Surface:
    c, a, b = (np.asarray(t, dtype=float) for t in (corner, eu, ev))
    g = geomdl_surface(np.array([[c, c + b], [c + a, c + a + b]]), np.ones((2, 2)), (1, 1),
                       [0, 0, 1, 1], [0, 0, 1, 1])
    return to_surface(g, sid, name=name)


def floor_and_wall(alpha: float, x_wall: float) -> Part:
    """A floor through the origin tilted by `alpha` (rad) about x (normal (0, -sin, cos)), for
    x in [-40, x_wall], and a vertical wall x = x_wall facing -x, 60 mm high."""
    t = np.array([0.0, np.cos(alpha), np.sin(alpha)])
    floor = _bilinear([-40, 0, 0] - 30 * t, [40 + x_wall, 0, 0], 60 * t, 0, "floor")
    wall = _bilinear([x_wall, -40, -30], [0, 0, 90], [0, 80, 0], 1, "wall")
    return Part([floor, wall])


FIG31_TILT = 0.0042


def fig31() -> Part:
    """Two surfaces built like thesis Fig. 3-1: S1 a flat floor z = 0 carrying the CC point at
    the origin (normal +z), S2 a bicubic B-spline roof beside it (x in [8, 15], y in [-6, 6])
    with two ridges along x at y = +-3; the imaginary ball radius over S2 has two local minima
    on its u = 0 edge about 0.0047 mm apart (the tilt makes the y > 0 one the global one)."""
    xs, ys = np.linspace(8, 15, 6), np.linspace(-6, 6, 12)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    Z = (4 + 3.5 * np.exp(-(((Y - 3) / 2) ** 2)) + 3.5 * np.exp(-(((Y + 3) / 2) ** 2))
         + FIG31_TILT * Y - 0.05 * (X - 8) ** 2)
    ku = np.array([0, 0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1, 1.0])
    kv = np.concatenate([[0, 0, 0], np.linspace(0, 1, 10), [1, 1, 1]])
    s2 = Surface(id=1, name="S2", kind="bspline", degree_u=3, degree_v=3, knots_u=ku, knots_v=kv,
                 ctrlpts=np.stack([X, Y, Z], axis=2))
    s1 = _bilinear([-6, -6, 0], [12, 0, 0], [0, 12, 0], 0, "S1")
    return Part([s1, s2])


def jittered_test_points(part: Part, n: int, seed: int):
    """TestPoints on an n x n (u, v) grid per surface shifted by a random fraction of a cell
    (seeded), with both domain edges kept: a sampling independent of the library's sampler."""
    from scipy.spatial import cKDTree

    from checker.geometry.sampling import TestPoints

    rng = np.random.default_rng(seed)
    pts, nrm, sid, uv, spc = [], [], [], [], []
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        off = rng.uniform(0, 1, 2)
        gu = np.unique(np.clip(np.concatenate([[0.0], (np.arange(n) + off[0]) / n, [1.0]]), 0, 1))
        gv = np.unique(np.clip(np.concatenate([[0.0], (np.arange(n) + off[1]) / n, [1.0]]), 0, 1))
        U, V = np.meshgrid(u0 + gu * (u1 - u0), v0 + gv * (v1 - v0), indexing="ij")
        ev = evaluate(s, U.ravel(), V.ravel())
        cell = np.hypot(np.linalg.norm(ev.du, axis=1) * (u1 - u0),
                        np.linalg.norm(ev.dv, axis=1) * (v1 - v0)) / n
        pts.append(ev.points)
        nrm.append(ev.normals)
        sid.append(np.full(U.size, s.id, dtype=np.int32))
        uv.append(np.column_stack([U.ravel(), V.ravel()]))
        spc.append(cell)
    P = np.concatenate(pts)
    return TestPoints(P, np.concatenate(nrm), np.concatenate(sid), np.concatenate(uv),
                      np.concatenate(spc), cKDTree(P))


def ball_radius_oracle(p: np.ndarray) -> np.ndarray:
    """Imaginary ball radius (with its cylindrical shank) for a CC point at the origin with
    normal +z, derived directly: sphere (h^2 + z^2) / (2 z) below the centre, h above it."""
    h2, z = p[:, 0] ** 2 + p[:, 1] ** 2, p[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = np.where(z > 0, (h2 + z * z) / (2 * z), np.inf)
    return np.where(z <= np.sqrt(h2), rs, np.sqrt(h2))


def free_form(seed: int, n: int = 7, size: float = 100.0, relief: float = 8.0) -> Part:
    """A random bicubic B-spline patch over a `size` mm square: an n x n net of poles jittered by
    3 mm in x and y, heights normal with `relief` mm deviation; normals up. Free-form parts the
    engine was not tuned on."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, size, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    P = np.stack([X + rng.uniform(-3, 3, X.shape), Y + rng.uniform(-3, 3, X.shape),
                  rng.normal(0.0, relief, X.shape)], axis=2)
    inner = np.linspace(0.0, 1.0, n - 2)[1:-1]
    kv = [0.0] * 4 + list(inner) + [1.0] * 4
    g = geomdl_surface(P, np.ones((n, n)), (3, 3), kv, kv)
    return Part([facing_up(to_surface(g, 0, name=f"free-form-{seed}"))])
