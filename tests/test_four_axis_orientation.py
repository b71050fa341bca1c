"""Orientation along the path: feasible intervals, seed-002 greedy smoothing and the shortest path.

The shortest path is checked against exhaustive enumeration on small problems, and against the
greedy smoothing (never more rotary motion)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from checker.four_axis.intervals import contains, feasible_intervals
from checker.four_axis.orientation import (
    greedy_smoothing,
    interval_optima,
    shortest_path_orientation,
    total_rotation,
)


def test_intervals_of_a_parabola_match_the_analytic_roots():
    b = np.linspace(-30, 30, 121)
    allowable = 10.0 - 0.01 * (b - 5.0) ** 2  # >= 9 for |b - 5| <= 10
    (ivs,) = feasible_intervals(b, allowable[None, :], 9.0)
    assert len(ivs) == 1
    lo, hi = ivs[0]
    assert lo == pytest.approx(-5.0, abs=0.02) and hi == pytest.approx(15.0, abs=0.02)


def test_intervals_split_open_at_the_range_ends_and_handle_inf():
    b = np.arange(0.0, 10.0)
    a = np.array([np.inf, 5, 1, 1, 5, 5, 1, 1, 5, np.inf])
    (ivs,) = feasible_intervals(b, a[None, :], 3.0)
    assert [round(lo, 6) for lo, _ in ivs] == [0.0, 3.5, 7.5]
    assert [round(hi, 6) for _, hi in ivs] == [1.5, 5.5, 9.0]
    (none,) = feasible_intervals(b, np.zeros((1, 10)), 3.0)
    assert none == []


def _brute_force(intervals, target, grid, w_change, w_original, widths):
    options = []
    for ivs in intervals:
        mask = np.zeros(grid.size, bool)
        for lo, hi in ivs:
            mask |= (grid >= lo - 1e-9) & (grid <= hi + 1e-9)
        options.append(grid[mask] if ivs else grid)
    best = np.inf
    for combo in itertools.product(*options):
        c = np.array(combo)
        if np.any(np.abs(np.diff(c)) > widths[1:] + 1e-9):
            continue
        cost = w_change * np.abs(np.diff(c)).sum() + w_original * np.abs(c - target).sum()
        best = min(best, cost)
    return best


@pytest.mark.parametrize("seed", range(6))
def test_shortest_path_is_optimal_against_enumeration(seed):
    rng = np.random.default_rng(seed)
    n = 4
    intervals = []
    for _ in range(n):
        k = rng.integers(0, 3)
        centres = rng.choice(np.arange(-8, 9, 4), k, replace=False)
        ivs = sorted((float(c) - 2.0, float(c) + 2.0) for c in centres)
        intervals.append(ivs)
    original = 2.0 * rng.integers(-5, 6, n)
    b_best = 2.0 * rng.integers(-5, 6, n)
    widths = np.full(n, 12.0)
    result = shortest_path_orientation(
        intervals, original, b_best, widths / 3.0, b_min=-10, b_max=10, grid_step=2.0,
        w_change=1.0, w_original=0.3, max_db_per_mm=3.0,
    )
    grid = np.arange(-10.0, 11.0, 2.0)
    feasible = np.array([bool(iv) for iv in intervals])
    target = np.where(feasible, original, b_best)
    expected = _brute_force(intervals, target, grid, 1.0, 0.3, widths)
    got = np.abs(np.diff(result.b)).sum() + 0.3 * np.abs(result.b - target).sum()
    assert got == pytest.approx(expected, abs=1e-9)
    for ivs, b in zip(intervals, result.b, strict=True):
        assert not ivs or contains(ivs, b)
    np.testing.assert_array_equal(result.feasible, feasible)


def test_greedy_follows_seed_002_and_shortest_path_moves_less():
    rng = np.random.default_rng(3)
    b = np.arange(-45.0, 45.01, 0.5)
    n = 300
    centre = 20.0 * np.sin(np.linspace(0, 6, n)) + rng.normal(0, 3, n)
    allowable = 6.0 - 0.004 * (b[None, :] - centre[:, None]) ** 2
    ivs = feasible_intervals(b, allowable, 4.0)
    optima = interval_optima(b, allowable, ivs)
    b_best = b[np.argmax(allowable, axis=1)]
    greedy, other = greedy_smoothing(optima, b_best)
    assert greedy.total_rotation <= other.total_rotation
    assert greedy.total_rotation == pytest.approx(total_rotation(greedy.b))
    # every greedy choice is one of the point's local optima (one per interval here)
    np.testing.assert_allclose(greedy.b, np.concatenate(optima))
    dp = shortest_path_orientation(
        ivs, np.full(n, np.nan), b_best, np.ones(n), b_min=-45, b_max=45, grid_step=0.5,
        w_change=1.0, w_original=0.1, max_db_per_mm=None, extra_candidates=np.concatenate(optima),
    )
    assert all(contains(iv, x) for iv, x in zip(ivs, dp.b, strict=True))
    assert dp.total_rotation <= greedy.total_rotation
    assert dp.total_rotation < 0.5 * greedy.total_rotation


def test_infeasible_points_are_flagged_and_kept():
    intervals = [[(-5.0, 5.0)], [], [(-5.0, 5.0)]]
    result = shortest_path_orientation(
        intervals, np.array([0.0, 0.0, 0.0]), np.array([0.0, 30.0, 0.0]), np.ones(3),
        b_min=-90, b_max=90, grid_step=1.0, w_change=1.0, w_original=0.1, max_db_per_mm=None,
    )
    assert result.b.shape == (3,)
    assert list(result.feasible) == [True, False, True]


def test_rate_limit_is_respected_or_relaxed_visibly():
    intervals = [[(-1.0, 1.0)], [(9.0, 11.0)]]
    limited = shortest_path_orientation(
        intervals, np.zeros(2), np.zeros(2), np.array([0.0, 4.0]), b_min=-20, b_max=20,
        grid_step=0.5, w_change=1.0, w_original=0.0, max_db_per_mm=2.0,
    )
    assert abs(limited.b[1] - limited.b[0]) <= 8.0 + 1e-9
    impossible = shortest_path_orientation(
        intervals, np.zeros(2), np.zeros(2), np.array([0.0, 1.0]), b_min=-20, b_max=20,
        grid_step=0.5, w_change=1.0, w_original=0.0, max_db_per_mm=2.0,
    )
    assert impossible.method.endswith("+relaxed")
