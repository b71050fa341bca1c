"""Parameters of points that lie on (or very near) a surface: Gauss-Newton from a start guess,
vectorised over all points, kept in the domain (newton_uv.py)."""

from __future__ import annotations

import numpy as np

from checker.geometry.evaluate import evaluate
from checker.geometry.newton_uv import newton_steps
from checker.part import Surface


def invert_points(
    surface: Surface,
    points: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    iterations: int = 30,
    tol: float = 1e-12,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u, v, distance): parameters of the foot points of `points (N, 3)` mm near the start
    guesses (u, v) (N,), and the remaining distance in mm (small when the point is on the
    surface). Gauss-Newton steps on |P - S(u, v)|^2 / 2: gradient -J^T r, matrix J^T J with
    J = [S_u S_v]."""
    (u0, u1), (v0, v1) = surface.domain
    u = np.clip(np.array(u, dtype=np.float64), u0, u1)
    v = np.clip(np.array(v, dtype=np.float64), v0, v1)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    lo = np.broadcast_to([u0, v0], (len(pts), 2))
    hi = np.broadcast_to([u1, v1], (len(pts), 2))
    active = np.arange(len(pts))
    for _ in range(iterations):
        if active.size == 0:
            break
        ev = evaluate(surface, u[active], v[active])
        J = np.stack([ev.du, ev.dv], axis=2)  # (K, 3, 2)
        r = pts[active] - ev.points
        step = newton_steps(-np.einsum("kia,ki->ka", J, r), np.einsum("kia,kib->kab", J, J),
                            np.column_stack([u[active], v[active]]), lo[active], hi[active])
        u[active] = np.clip(u[active] + step[:, 0], u0, u1)
        v[active] = np.clip(v[active] + step[:, 1], v0, v1)
        moved = np.hypot(step[:, 0], step[:, 1]) > tol * max(u1 - u0, v1 - v0, 1.0)
        active = active[moved]
    dist = np.linalg.norm(pts - evaluate(surface, u, v).points, axis=1)
    return u, v, dist
