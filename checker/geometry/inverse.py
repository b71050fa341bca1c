"""Parameters of points that lie on (or very near) a surface: Gauss-Newton from a start guess,
vectorised over all points, clipped to the domain."""

from __future__ import annotations

import numpy as np

from checker.geometry.evaluate import evaluate
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
    surface). Steps are taken with the 2x2 normal equations of [S_u S_v]."""
    (u0, u1), (v0, v1) = surface.domain
    u = np.clip(np.array(u, dtype=np.float64), u0, u1)
    v = np.clip(np.array(v, dtype=np.float64), v0, v1)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    active = np.arange(len(pts))
    for _ in range(iterations):
        if active.size == 0:
            break
        ev = evaluate(surface, u[active], v[active])
        r = pts[active] - ev.points
        a = np.einsum("ij,ij->i", ev.du, ev.du)
        b = np.einsum("ij,ij->i", ev.du, ev.dv)
        c = np.einsum("ij,ij->i", ev.dv, ev.dv)
        ru = np.einsum("ij,ij->i", ev.du, r)
        rv = np.einsum("ij,ij->i", ev.dv, r)
        det = a * c - b * b
        ok = det > 1e-300
        det = np.where(ok, det, 1.0)
        du = np.where(ok, (c * ru - b * rv) / det, 0.0)
        dv = np.where(ok, (a * rv - b * ru) / det, 0.0)
        u[active] = np.clip(u[active] + du, u0, u1)
        v[active] = np.clip(v[active] + dv, v0, v1)
        moved = np.hypot(du, dv) > tol * max(u1 - u0, v1 - v0, 1.0)
        active = active[moved]
    dist = np.linalg.norm(pts - evaluate(surface, u, v).points, axis=1)
    return u, v, dist
