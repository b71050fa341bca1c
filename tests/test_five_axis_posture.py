"""The 5-axis posture planners (checker/five_axis/posture.py) against independent answers: the
least total turn through per-point feasible intervals is a linear programme (scipy's HiGHS);
the greedy smoothing of Jun, Lee and Cha (2002) traced by hand; the fairing's feasibility; the
metrics on closed forms."""

import numpy as np
import pytest
from scipy.optimize import linprog

from checker.five_axis.posture import (
    Candidates,
    greedy_smoothing,
    mb_spline_fairing,
    posture_metrics,
    shortest_posture,
)

STEP = 5.0
TILTS = np.arange(-60.0, 60.0 + STEP / 2, STEP)


def _in_plane(tilt_deg: np.ndarray) -> np.ndarray:
    t = np.radians(tilt_deg)
    return np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], axis=-1)


def _candidates(lo: np.ndarray, hi: np.ndarray, score=None) -> Candidates:
    """Axes tilted in the XZ plane on a 5-degree grid; feasible where lo_i <= tilt <= hi_i
    (several intervals per point when lo/hi are lists)."""
    n = len(lo)
    axes = np.broadcast_to(_in_plane(TILTS), (n, len(TILTS), 3)).copy()
    feas = np.zeros((n, len(TILTS)), bool)
    tilt = TILTS
    for i in range(n):
        for a, b in zip(np.atleast_1d(lo[i]), np.atleast_1d(hi[i]), strict=True):
            feas[i] |= (tilt >= a - 1e-9) & (tilt <= b + 1e-9)
    sc = -np.abs(TILTS)[None].repeat(n, 0) if score is None else score
    return Candidates(axes, feas, sc, (1, len(TILTS)))


def _tilts(axis: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(axis[:, 0], axis[:, 2]))


def _lp_least_turn(lo, hi, limit=None):
    """min sum |t_i - t_(i-1)| s.t. lo <= t <= hi (and |t_i - t_(i-1)| <= limit), with slack
    variables d_i >= |t_i - t_(i-1)|. Integral data and difference constraints: the optimum
    is attained on the 5-degree grid, so the DP over the grid must reach it."""
    n = len(lo)
    c = np.r_[np.zeros(n), np.ones(n - 1)]
    rows, rhs = [], []
    for i in range(1, n):
        for sgn in (1, -1):
            r = np.zeros(2 * n - 1)
            r[i], r[i - 1], r[n + i - 1] = sgn, -sgn, -1
            rows.append(r)
            rhs.append(0.0)
    bounds = [(a, b) for a, b in zip(lo, hi, strict=True)]
    bounds += [(0, limit)] * (n - 1)
    res = linprog(c, A_ub=np.array(rows), b_ub=rhs, bounds=bounds, method="highs")
    assert res.status == 0
    return res.fun


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_least_turn_equals_the_linear_programme(seed):
    rng = np.random.default_rng(seed)
    n = 40
    centre = np.cumsum(rng.integers(-3, 4, n)) * STEP
    centre = np.clip(centre, -40, 40)
    lo = centre - rng.integers(0, 3, n) * STEP
    hi = centre + rng.integers(0, 3, n) * STEP
    s = np.arange(n, dtype=float)
    post = shortest_posture(_candidates(lo, hi), s, _in_plane(np.zeros(n)),
                            max_turn_per_mm=np.inf, w_pref=0.0)
    t = _tilts(post.axis)
    assert post.feasible.all()
    assert np.all((t >= lo - 1e-6) & (t <= hi + 1e-6))
    assert np.abs(np.diff(t)).sum() == pytest.approx(_lp_least_turn(lo, hi), abs=1e-6)


def test_turn_limit_holds_and_matches_the_linear_programme():
    lo = np.array([-40.0, -40, -20, 10, 10, 10, -15, -15])
    hi = lo + 10.0
    s = np.arange(8) * 2.0  # 2 mm steps; 10 degrees/mm allows 20 degrees per step
    post = shortest_posture(_candidates(lo, hi), s, _in_plane(np.zeros(8)),
                            max_turn_per_mm=np.radians(10.0), w_pref=0.0)
    t = _tilts(post.axis)
    assert post.method == "shortest path"
    assert np.abs(np.diff(t)).max() <= 20.0 + 1e-6
    assert np.abs(np.diff(t)).sum() == pytest.approx(_lp_least_turn(lo, hi, 20.0), abs=1e-6)


def test_an_impossible_turn_limit_is_said_and_planned_without_it():
    lo, hi = np.array([-60.0, 50.0]), np.array([-50.0, 60.0])
    post = shortest_posture(_candidates(lo, hi), np.array([0.0, 1.0]), _in_plane(np.zeros(2)),
                            max_turn_per_mm=np.radians(10.0))
    assert post.method == "shortest path (turn limit exceeded)"
    assert _tilts(post.axis) == pytest.approx([-50.0, 50.0], abs=1e-6)


def test_a_point_without_a_feasible_axis_keeps_its_preferred_axis_and_is_flagged():
    lo = np.array([0.0, 100.0, 0.0])
    hi = np.array([10.0, 110.0, 10.0])
    pref = _in_plane(np.array([0.0, 7.0, 0.0]))
    post = shortest_posture(_candidates(lo, hi), np.arange(3.0), pref, max_turn_per_mm=1.0)
    assert post.feasible.tolist() == [True, False, True]
    assert _tilts(post.axis)[1] == pytest.approx(7.0)


def test_seed_002_greedy_takes_the_nearest_local_optimum_forward_or_backward():
    """Two regions at the middle point: [-60, -40] (optimum -40, the score is -|tilt|) and
    [40, 60] (optimum 40). Point 0 allows only [-60, -50] (optimum -50); point 2 only [45, 60]
    (optimum 45). Forward: -50 -> -40 (10) -> 45 (85): 95. Backward: 45 -> 40 (5) -> -50
    (90): 95, a tie which forward wins. The middle point with the forward pass is -40."""
    lo = [[-60.0], [-60.0, 40.0], [45.0]]
    hi = [[-50.0], [-40.0, 60.0], [60.0]]
    post = greedy_smoothing(_candidates(lo, hi), _in_plane(np.zeros(3)))
    assert _tilts(post.axis) == pytest.approx([-50.0, -40.0, 45.0], abs=1e-6)
    # backward wins when the last point pulls harder: point 0 now allows [-60, 60]
    lo2 = [[-60.0], [-60.0, 40.0], [45.0]]
    hi2 = [[60.0], [-40.0, 60.0], [60.0]]
    post2 = greedy_smoothing(_candidates(lo2, hi2), _in_plane(np.zeros(3)))
    # forward: 0 -> -40 or 40 (40) -> 45 ... first pick is the best of point 0 = 0 degrees;
    # nearest optimum at point 1 is +-40 (tie, -40 first) then 45: 40 + 85 = 125;
    # backward: 45 -> 40 (5) -> 0 (40) = 45: backward wins
    assert _tilts(post2.axis) == pytest.approx([0.0, 40.0, 45.0], abs=1e-6)


def test_fairing_smooths_a_zigzag_and_every_axis_stays_feasible():
    n = 60
    zig = np.where(np.arange(n) % 2 == 0, -10.0, 10.0)
    planned = shortest_posture(_candidates(zig, zig), np.arange(n, dtype=float),
                               _in_plane(np.zeros(n)), max_turn_per_mm=np.inf)
    forbidden = (-3.0, 3.0)  # a band the oracle rejects

    def feasible_at(rows, axes):
        t = _tilts(axes)
        return ~((t > forbidden[0]) & (t < forbidden[1]))

    faired = mb_spline_fairing(planned, feasible_at)
    t = _tilts(faired.axis)
    assert feasible_at(np.arange(n), faired.axis).all()
    s = np.arange(n, dtype=float)
    before = posture_metrics(_tilts(planned.axis)[:, None], s)
    after = posture_metrics(t[:, None], s)
    assert after.peak_acceleration_deg_per_mm2 < 0.5 * before.peak_acceleration_deg_per_mm2
    assert after.total_motion_deg < before.total_motion_deg


def test_fairing_keeps_a_smooth_posture_and_segment_ends():
    """A posture on a uniform cubic B-spline's own control polygon that is a straight line is a
    fixed point: (P_(i-1) + 4 P_i + P_(i+1)) / 6 = P_i for collinear equally spaced points
    (before normalising; the tilts here are linear so the axes differ from the line only by
    their length, which the fairing normalises back)."""
    t = np.arange(-20.0, 20.0 + 1, STEP)  # on the candidates' grid
    n = len(t)
    planned = shortest_posture(_candidates(t, t), np.arange(n, dtype=float),
                               _in_plane(np.zeros(n)), max_turn_per_mm=np.inf)
    faired = mb_spline_fairing(planned, lambda r, a: np.ones(len(r), bool), passes=3)
    assert _tilts(faired.axis)[[0, -1]] == pytest.approx([-20.0, 20.0], abs=1e-9)
    assert np.abs(_tilts(faired.axis) - t).max() < 0.05


def test_metrics_on_closed_forms():
    s = np.linspace(0.0, 10.0, 101)
    lin = posture_metrics(np.column_stack([3.0 * s, -s]), s)
    assert lin.total_motion_deg == pytest.approx(40.0)
    assert lin.peak_velocity_deg_per_mm == pytest.approx(3.0)
    assert lin.peak_acceleration_deg_per_mm2 == pytest.approx(0.0, abs=1e-9)
    quad = posture_metrics((0.5 * s**2)[:, None], s)  # a'' = 1 deg/mm^2
    assert quad.peak_acceleration_deg_per_mm2 == pytest.approx(1.0, rel=1e-6)
    starts = np.zeros(101, bool)
    starts[50] = True
    jump = posture_metrics(np.where(s < 5, 0.0, 90.0)[:, None], s, starts)
    assert jump.total_motion_deg == pytest.approx(0.0)
