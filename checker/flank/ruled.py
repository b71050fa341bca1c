"""The naive flank poses of a ruled surface (the starting path of the optimisation of Gong and Wang
2009): the tool axis along the ruling, offset along the surface normal at the ruling's middle by the
cutter's radius there, the tip a margin below the ruling's lower end. Part frame, mm."""

from __future__ import annotations

import numpy as np

from checker.cutter import Cutter
from checker.flank.envelope import profile
from checker.geometry.evaluate import evaluate
from checker.part import Surface


def naive_poses(surface: Surface, cutter: Cutter, u: np.ndarray, below: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """(tips, axes) (K, 3) for the rulings at u (K,) (the surface straight in v, from v0 up
    to v1): axis along S(u, v1) - S(u, v0), the axis line through S(u, v_mid) + rho n (n the
    normal out of the material there, rho the profile radius at that height), the tip `below`
    mm under the ruling's lower end."""
    (_, _), (v0, v1) = surface.domain
    u = np.asarray(u, dtype=float)
    lo = evaluate(surface, u, np.full_like(u, v0)).points
    hi = evaluate(surface, u, np.full_like(u, v1)).points
    mid = evaluate(surface, u, np.full_like(u, 0.5 * (v0 + v1)))
    axes = (hi - lo) / np.linalg.norm(hi - lo, axis=1, keepdims=True)
    z_mid = below + 0.5 * np.linalg.norm(hi - lo, axis=1)
    rho, _ = profile(cutter, z_mid)
    tips = mid.points + rho[:, None] * mid.normals - z_mid[:, None] * axes
    return tips, axes


def hyperbolic_paraboloid(half_x: float, height: float, c: float) -> Surface:
    """The wall y = x z / c, x in [-half_x, half_x], z in [0, height], as its exact bilinear
    B-spline (u along x, v along z, straight in both: rulings x = const and z = const); the
    normal (z/c, -1, x/c) points to -y, out of the material."""
    x, z = (-half_x, half_x), (0.0, height)
    ctrl = np.array([[[xi, xi * zj / c, zj] for zj in z] for xi in x])
    k = np.array([0.0, 0.0, 1.0, 1.0])
    return Surface(id=0, name="hypar", kind="bspline", degree_u=1, degree_v=1,
                   knots_u=k, knots_v=k, ctrlpts=ctrl)
