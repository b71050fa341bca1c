"""The refinement's trust-region step (engine/refine/steps.py `_trust_region`): the point of the
disc |p| <= radius where the quadratic g.p + p.H.p / 2 is least, against a brute force over the
disc (its boundary at 20,000 angles and the interior Newton point), on random 2x2 problems
from convex to indefinite, near the hard case (g almost orthogonal to the lowest eigenvector)
and with scales from 1e-6 to 1e6."""

from __future__ import annotations

import numpy as np
import pytest

from checker.engine.refine.steps import _trust_region

_ANGLES = np.linspace(0.0, 2.0 * np.pi, 20_000, endpoint=False)


def _model(g, H, p):
    return p @ g + 0.5 * np.einsum("...i,ij,...j->...", p, H, p)


def _brute_minimum(g, H, radius):
    """The least model value over the disc: on its boundary (fine angles), or at the interior
    stationary point where H is positive definite and that lies inside."""
    ring = radius * np.column_stack([np.cos(_ANGLES), np.sin(_ANGLES)])
    best = _model(g, H, ring).min()
    if np.linalg.eigvalsh(H)[0] > 0.0:
        p = -np.linalg.solve(H, g)
        if np.linalg.norm(p) <= radius:
            best = min(best, _model(g, H, p))
    return best


def _problems(seed: int, count: int):
    rng = np.random.default_rng(seed)
    for k in range(count):
        scale = 10.0 ** rng.uniform(-3, 5)
        A = rng.normal(size=(2, 2)) * scale
        H = A + A.T
        if k % 3 == 0:  # near the hard case: g almost along the highest eigenvector
            w, v = np.linalg.eigh(H)
            g = v[:, 1] * scale * rng.uniform(0.1, 1) + v[:, 0] * scale * 1e-9
        else:
            g = rng.normal(size=2) * 10.0 ** rng.uniform(-3, 3)
        yield g, H, 10.0 ** rng.uniform(-4, 1)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_step_minimises_the_model_over_the_disc(seed):
    for g, H, radius in _problems(seed, 300):
        p = np.array(_trust_region(g[0], g[1], H[0, 0], H[0, 1], H[1, 1], radius))
        assert np.linalg.norm(p) <= radius * (1.0 + 1e-9), "the step leaves the trust region"
        best = _brute_minimum(g, H, radius)
        # the brute force's angular spacing costs up to |H| (radius dtheta)^2 / 2 + |g| radius
        # dtheta^2 / 2 at the boundary
        slack = (np.abs(np.linalg.eigvalsh(H)).max() * radius ** 2 + np.linalg.norm(g) * radius) \
            * (2.0 * np.pi / _ANGLES.size) ** 2 + 1e-9 * (abs(best) + 1e-300)
        assert _model(g, H, p) <= best + slack


def test_a_positive_definite_model_with_its_minimum_inside_takes_the_newton_step():
    H = np.array([[4.0, 1.0], [1.0, 3.0]])
    g = np.array([1.0, -2.0])
    p = np.array(_trust_region(g[0], g[1], H[0, 0], H[0, 1], H[1, 1], 10.0))
    assert np.allclose(p, -np.linalg.solve(H, g), rtol=1e-12, atol=0.0)
