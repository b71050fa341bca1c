"""Best B and feasible intervals on analytic allowable-size functions, against a dense scan."""

from __future__ import annotations

import numpy as np
import pytest

from checker.b_axis import axis_for_b, b_for_axis, check_b_range, check_four_axis
from checker.errors import PathcheckError
from checker.four_axis.best_b import END_TOLERANCE, best_b
from checker.four_axis.over_b import facing_edges


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


class _Counted:
    """An allowable-size function that counts the (point, B) rows it evaluated."""

    def __init__(self, fn):
        self.fn, self.rows = fn, 0

    def __call__(self, rows, b):
        self.rows += len(rows)
        return self.fn(rows, b)


def _sloped(rows: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A peak with curved flanks: sizes falling off 0.05 to 0.12 mm per degree either side,
    faster further out (a parabola on each flank)."""
    x = b - 3.0 * (rows % 7)
    return 8.0 - (0.05 + 0.007 * (rows % 11)) * np.abs(x) - 0.002 * x * x


def test_smooth_ends_take_fewer_probes_than_bisection():
    """Ends of an A(B) whose flanks are parabolas, from the parabola through the last three
    feasible B: within END_TOLERANCE of the true crossing on the feasible side, from the two
    probes either side of its crossing per end (five bisection rounds take 6 degrees to
    0.2)."""
    n = 40
    result = best_b(_sloped, n, b_min=-90, b_max=90, coarse_step=6.0, tolerance=0.01,
                    required=3.0)
    dense = np.arange(-90, 90.0001, 0.0005)
    for row in range(n):
        (lo, hi), = result.feasible[row]
        true_lo, true_hi = dense[_sloped(np.full(dense.size, row), dense) >= 3.0][[0, -1]]
        assert true_lo - 1e-9 <= lo <= true_lo + END_TOLERANCE
        assert true_hi - END_TOLERANCE <= hi <= true_hi + 1e-9
    assert _end_probes(_sloped, n, 3.0) <= 2 * (2 * n)


def _end_probes(fn, n: int, required: float, edge_fn=None) -> int:
    """(point, B) probes that best_b's interval ends took."""
    import checker.four_axis.best_b as bb

    counted = _Counted(fn)
    original = bb._unless_below

    def probes(f, bound, rows, b, against):
        counted.rows += len(rows)
        return original(f, bound, rows, b, against)

    bb._unless_below = probes
    try:
        best_b(fn, n, b_min=-90, b_max=90, coarse_step=6.0, tolerance=0.01,
               required=required, edge_fn=edge_fn)
    finally:
        bb._unless_below = original
    return counted.rows


def test_an_end_at_the_facing_edge_takes_one_probe():
    """Sizes constant up to the B where the normal turns away from the tool axis, 0 past it
    (n . axis(B) = 0: `facing_edges`): the end within END_TOLERANCE inside that edge, from one
    probe per end instead of five bisection rounds."""
    n = 12
    tilt = np.radians(np.linspace(20.0, 70.0, n))
    normal = np.column_stack([np.sin(tilt), np.zeros(n), np.cos(tilt)])
    contacts = type("Contacts", (), {"normal": normal})()
    edge_b = np.degrees(np.arctan2(normal[:, 2], normal[:, 0]))  # n . axis(edge_b) = 0

    def fn(rows, b):
        facing = np.einsum("ij,ij->i", normal[rows], axis_for_b(b)) > 1e-12
        return np.where(facing, 5.0, 0.0)

    result = best_b(fn, n, b_min=-90, b_max=90, coarse_step=6.0, tolerance=0.01, required=3.0,
                    edge_fn=facing_edges(contacts))
    for row in range(n):
        ends = [v for iv in result.feasible[row] for v in iv if -90 < v < 90]
        assert len(ends) == 1
        assert edge_b[row] - END_TOLERANCE <= ends[0] < edge_b[row]
        assert fn(np.array([row]), np.array([ends[0]]))[0] >= 3.0
    assert _end_probes(fn, n, 3.0, facing_edges(contacts)) == n
    assert _end_probes(fn, n, 3.0) == 5 * n


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
