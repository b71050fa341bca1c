"""The projected Newton step in (u, v) (checker/geometry/newton_uv.py) against its closed forms:
the full Newton step of a quadratic, the least-norm step onto a level of a linear height, and
the active-set step at a domain bound."""

from __future__ import annotations

import numpy as np

from checker.geometry.newton_uv import newton_step, newton_steps

BOX = (0.0, 1.0, 0.0, 1.0)


def test_positive_definite_quadratic_takes_its_minimiser():
    """f = g.d + d^T H d / 2 with H positive definite: one step lands on -H^-1 g."""
    rng = np.random.default_rng(5)
    A = rng.normal(size=(50, 2, 2))
    H = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(2)
    g = rng.normal(size=(50, 2)) * 1e-3
    uv = np.full((50, 2), 0.5)
    steps = newton_steps(g, H, uv, np.zeros((50, 2)), np.ones((50, 2)))
    np.testing.assert_allclose(steps, -np.linalg.solve(H, g[..., None])[..., 0], rtol=1e-12,
                               atol=1e-15)


def test_rank_one_step_reaches_the_level_by_the_shortest_step():
    """A linear height h = a.(u, v) + c, brought to 0: the objective h^2 / 2 has gradient
    h a and matrix a a^T; the step is -h a / |a|^2, which sets h to 0 and is the shortest."""
    a, h = np.array([3.0, -4.0]), 0.25
    du, dv = newton_step(h * a[0], h * a[1], a[0] ** 2, a[0] * a[1], a[1] ** 2, 0.5, 0.5, *BOX,
                         False, False)
    assert np.isclose(h + a @ [du, dv], 0.0, atol=1e-15)
    np.testing.assert_allclose([du, dv], -h * a / (a @ a), rtol=1e-12)


def test_a_parameter_on_its_bound_is_held_and_the_other_steps_alone():
    """At u = 0 a step towards u < 0 is held: dv = -g_v / H_vv (the 1-D Newton step); on a
    closed direction (the seam of a revolved surface) the full step is kept."""
    H = np.array([[2.0, 0.5], [0.5, 1.0]])
    g = np.array([1.0, -0.3])  # the full step has du < 0
    full = -np.linalg.solve(H, g)
    assert full[0] < 0.0
    held = newton_step(g[0], g[1], H[0, 0], H[0, 1], H[1, 1], 0.0, 0.5, *BOX, False, False)
    np.testing.assert_allclose(held, [0.0, -g[1] / H[1, 1]], rtol=1e-12)
    wraps = newton_step(g[0], g[1], H[0, 0], H[0, 1], H[1, 1], 0.0, 0.5, *BOX, True, False)
    np.testing.assert_allclose(wraps, full, rtol=1e-12)
    corner = newton_step(1.0, 1.0, 1.0, 0.0, 1.0, 0.0, 0.0, *BOX, False, False)
    assert corner == (0.0, 0.0)
