"""The error between the envelope and the design surface along the envelope's normal (Gong and Wang
2009 §2.1, definition B; docs/MATH.md §12.3): from each grazing point p with the cutter's outward
normal n, the line p + s n meets the surface at s; the error is e = -s, so e > 0 is an overcut
(the envelope lies inside the material, beyond the design surface) and e < 0 an undercut
(material left). Part frame, mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.cutter import Cutter
from checker.flank.envelope import grazing
from checker.flank.spline_motion import ToolMotion
from checker.geometry.evaluate import evaluate
from checker.geometry.inverse import invert_points
from checker.geometry.nearest import PointTree
from checker.part import Surface

HIT_TOL = 1e-6  # mm: a normal line meets the surface when its residual is below this


def grid_uv(surface: Surface, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) (n, n) an even grid over the surface's domain."""
    (u0, u1), (v0, v1) = surface.domain
    return np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")


def foot_points(surface: Surface, points: np.ndarray, grid: int = 33
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u, v, distance) (K,) of the foot points of `points` (K, 3) on the surface, started from
    the nearest node of a grid x grid sample."""
    U, V = grid_uv(surface, grid)
    nodes = evaluate(surface, U.ravel(), V.ravel()).points
    _, k = PointTree(nodes).query(points)
    return invert_points(surface, points, U.ravel()[k], V.ravel()[k])


def normal_hits(surface: Surface, p: np.ndarray, n: np.ndarray, uv: np.ndarray | None = None,
                iterations: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s, uv, hit): where the lines p + s n (K, 3) meet the surface, s (K,) mm, uv (K, 2), hit
    (K,) False where the line leaves the domain or misses (s is then the Newton's last value,
    finite). Newton on S(u, v) - p - s n = 0 from `uv` (K, 2), else from the foot point, the
    parameters kept in the domain."""
    (u0, u1), (v0, v1) = surface.domain
    if uv is None:
        u, v, _ = foot_points(surface, p)
    else:
        u, v = np.array(uv[:, 0], dtype=float), np.array(uv[:, 1], dtype=float)
    s = np.einsum("ij,ij->i", evaluate(surface, u, v).points - p, n)
    active = np.arange(len(p))
    for _ in range(iterations):
        if active.size == 0:
            break
        ev = evaluate(surface, u[active], v[active])
        F = ev.points - p[active] - s[active, None] * n[active]
        J = np.stack([ev.du, ev.dv, -n[active]], axis=2)  # (K, 3, 3)
        JT = np.transpose(J, (0, 2, 1))
        H = JT @ J + 1e-14 * np.eye(3)
        step = np.linalg.solve(H, -np.einsum("kab,kb->ka", JT, F)[..., None])[..., 0]
        u_new = np.clip(u[active] + step[:, 0], u0, u1)
        v_new = np.clip(v[active] + step[:, 1], v0, v1)
        moved = (np.abs(u_new - u[active]) + np.abs(v_new - v[active]) > 1e-13) | (
            np.abs(step[:, 2]) > 1e-11)
        u[active], v[active] = u_new, v_new
        s[active] += step[:, 2]
        active = active[moved]
    residual = np.linalg.norm(evaluate(surface, u, v).points - p - s[:, None] * n, axis=1)
    return s, np.column_stack([u, v]), residual < HIT_TOL


def axis_side(surface: Surface, tip: np.ndarray, axis: np.ndarray, z: float) -> np.ndarray:
    """(T, 3) the direction from the axis towards the design surface: minus the surface's
    normal (out of the material) at the foot point of the axis point z mm above the tip."""
    u, v, _ = foot_points(surface, tip + z * axis)
    return -evaluate(surface, u, v).normals


@dataclass(frozen=True)
class ErrorField:
    """The envelope's error at (T, Z) = (path parameters `t`, heights `z`): `error` mm (> 0
    overcut, < 0 undercut, nan where there is no grazing point or its normal line misses the
    surface), `raw` the same with the misses' last Newton value (finite where there is a
    grazing point; what the optimiser follows), `side` (T, 3) the side of the surface, grazing
    `points` and `normals` (T, Z, 3), `uv` (T, Z, 2) where the normal lines
    meet the surface, `segment` (T,) the move (pose i -> i + 1) each t lies on, `pose` (T,) the
    pose index at a pose's own t, else -1."""

    t: np.ndarray
    z: np.ndarray
    error: np.ndarray
    raw: np.ndarray
    side: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    uv: np.ndarray
    segment: np.ndarray
    pose: np.ndarray


def path_samples(t_poses: np.ndarray, per_move: int) -> tuple[np.ndarray, np.ndarray]:
    """(t, pose): the poses' parameters with `per_move - 1` more between each pair; pose (T,)
    the pose index at the poses, -1 between."""
    n = len(t_poses)
    f = np.arange(per_move) / per_move
    t = (t_poses[:-1, None] + f[None, :] * np.diff(t_poses)[:, None]).ravel()
    pose = np.where(np.tile(f == 0.0, n - 1), np.repeat(np.arange(n - 1), per_move), -1)
    return np.append(t, t_poses[-1]), np.append(pose, n - 1)


def envelope_error(cutter: Cutter, motion: ToolMotion, surface: Surface, z: np.ndarray,
                   per_move: int = 4, side: np.ndarray | None = None,
                   uv: np.ndarray | None = None) -> ErrorField:
    """The error field of the motion's envelope against `surface` at heights z (Z,) mm above
    the tip, sampled at the poses and `per_move - 1` parameters between each pair. `side`
    (T, 3) and the Newton starts `uv` (T, Z, 2) may be given (the optimiser keeps them from
    the first field): else the axis' side of the surface and the foot points."""
    t, pose = path_samples(motion.t, per_move)
    state = motion.at(t)
    if side is None:
        side = axis_side(surface, state.tip, state.axis, float(np.median(z)))
    g = grazing(cutter, state, z, side)
    err = np.full(g.valid.shape, np.nan)
    raw = np.full(g.valid.shape, np.nan)
    hit_uv = np.full(g.valid.shape + (2,), np.nan)
    if g.valid.any():
        start = None if uv is None else np.nan_to_num(uv[g.valid], nan=0.5)
        s, found, hit = normal_hits(surface, g.points[g.valid], g.normals[g.valid], start)
        raw[g.valid] = -s
        err[g.valid] = np.where(hit, -s, np.nan)
        hit_uv[g.valid] = found
    segment = np.clip(np.searchsorted(motion.t, t, side="right") - 1, 0, len(motion.t) - 2)
    return ErrorField(t, np.asarray(z, float), err, raw, side, g.points, g.normals, hit_uv,
                      segment, pose)
