"""Best B and feasible intervals on analytic allowable-size functions, against a dense scan."""

from __future__ import annotations

import numpy as np
import pytest

from checker.b_axis import axis_for_b, b_for_axis, check_b_range, check_four_axis
from checker.errors import PathcheckError
from checker.four_axis.best_b import END_TOLERANCE, best_b


def _two_peaks(rows: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A max-min style function: min of two V-shaped limits plus a second, lower hump."""
    c1 = 10.0 + 3.0 * np.sin(rows)
    c2 = -40.0 + 5.0 * np.cos(rows)
    hump1 = 6.0 - 0.05 * np.abs(b - c1) - 0.002 * (b - c1) ** 2
    hump2 = 5.9 - 0.1 * np.abs(b - c2)
    return np.maximum(np.minimum(hump1, 6.0), hump2)


def test_best_b_matches_a_dense_scan():
    n = 50
    result = best_b(_two_peaks, n, b_min=-90, b_max=90, coarse_step=2.0, tolerance=0.01,
                    required=5.0)
    dense = np.arange(-90, 90.0001, 0.001)
    rows = np.repeat(np.arange(n), dense.size)
    values = _two_peaks(rows, np.tile(dense, n)).reshape(n, -1)
    np.testing.assert_allclose(result.b_best, dense[np.argmax(values, axis=1)], atol=0.02)
    np.testing.assert_allclose(result.allowable_at_best, values.max(axis=1), atol=1e-4)
    for row in range(n):
        ok = values[row] >= 5.0
        edges = np.flatnonzero(np.diff(ok.astype(int)))
        got = [v for iv in result.feasible[row] for v in iv if -90 < v < 90]
        np.testing.assert_allclose(sorted(got), dense[edges + 1 * (~ok[edges])],
                                   atol=END_TOLERANCE)


def test_unbounded_plateau_keeps_the_reference_angle():
    def fn(rows, b):
        return np.where(np.abs(b) < 30, np.inf, 3.0)

    result = best_b(fn, 3, b_min=-60, b_max=60, coarse_step=5.0, tolerance=0.01, required=2.0,
                    reference=np.array([10.0, -20.0, 80.0]))
    assert np.isinf(result.allowable_at_best).all()
    np.testing.assert_allclose(result.b_best, [10.0, -20.0, 25.0])
    assert result.feasible[0] == [(-60.0, 60.0)]


def test_axis_convention_round_trips_and_follows_design():
    b = np.array([-120.0, -30.0, 0.0, 45.0, 90.0])
    axes = axis_for_b(b)
    np.testing.assert_allclose(b_for_axis(axes), b, atol=1e-12)
    np.testing.assert_allclose(axis_for_b(np.array([90.0]))[0], [-1.0, 0.0, 0.0], atol=1e-15)


def test_non_four_axis_path_names_the_line():
    axes = np.array([[0, 0, 1.0], [0.1, 0.2, 0.97], [0, 0.3, 0.95]])
    with pytest.raises(PathcheckError) as err:
        check_four_axis(axes, np.array([10, 11, 12]), "job.apt", 1e-6)
    assert "job.apt:11:" in str(err.value) and "2 axes" in str(err.value)
    with pytest.raises(PathcheckError, match="outside the machine's limits"):
        check_b_range(-200, 0, -180, 180)
    with pytest.raises(PathcheckError, match="LO < HI"):
        check_b_range(10, 0, -180, 180)
