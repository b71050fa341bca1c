"""The tool axis along a 5-axis path, inside each point's feasible set (docs/MATH.md §13).

Three planners over the same candidates (each CC point's grid of tool axes, which of them are
feasible, and a score per axis, larger better, e.g. the allowable cutter size):
- `shortest_posture`: dynamic programming over the candidates. Cost = the turn dθ (radians)
  between consecutive unit axes + `w_pref` times the turn from the point's preferred axis (the
  CAM's own, by default); at most `max_turn_per_mm * ds` radians of turn over a path step of
  length ds (mm). Rows where a new segment starts (after a
  rapid or an operation change) carry no turn cost and no turn limit.
- `mb_spline_fairing`: Hwang et al. (2011): the posture vectors' end points taken as the
  control points of a uniform cubic B-spline (C2), sampled again at the same parameters, which
  passes between them; where the faired axis is not feasible it is blended back towards the
  planned axis (which is) until every axis is feasible.
- `greedy_smoothing`: Jun, Lee and Cha (2002), Algorithm II: the local optimum of each
  feasible region (connected on the grid); forward smoothing from the first point's best and
  backward smoothing from the last point's, each step taking the local optimum nearest to the
  previous choice; the pass with the smaller total C-distance wins.
`posture_metrics` measures a result: total rotary motion, the largest angular velocity per mm and
acceleration per mm² of the machine's rotary angles (degrees) along the path.
A point without a feasible axis keeps its preferred axis and is flagged, never dropped.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy import ndimage


class Candidates(NamedTuple):
    """Per CC point a (lead, tilt) grid of tool axes, flattened: `axes (N, G, 3)` unit, part
    frame; `feasible (N, G)` bool; `score (N, G)` larger is better; `grid (L, T)` with
    L * T = G, the grid's shape (lead-major), which says which candidates are neighbours."""

    axes: np.ndarray
    feasible: np.ndarray
    score: np.ndarray
    grid: tuple[int, int]


class Posture(NamedTuple):
    """The chosen unit axis per point `axis (N, 3)`, whether it is feasible `feasible (N,)`,
    and the planner that chose it."""

    axis: np.ndarray
    feasible: np.ndarray
    method: str


def _steps(s: np.ndarray) -> np.ndarray:
    """(N,) path length from the previous point, mm (0 for the first)."""
    return np.concatenate([[0.0], np.diff(np.asarray(s, dtype=float))])


@njit(cache=True)
def _turn(a, b):  # pragma: no cover - compiled
    return np.arccos(min(1.0, max(-1.0, a @ b)))


@njit(cache=True)
def _dp(axes, feasible, pref, w_pref, cos_limit, starts):  # pragma: no cover - compiled
    n, g = feasible.shape
    inf = np.inf
    cost = np.full((n, g), inf)
    back = np.full((n, g), -1, np.int64)
    for h in range(g):
        if feasible[0, h]:
            cost[0, h] = w_pref * _turn(axes[0, h], pref[0])
    for i in range(1, n):
        for h in range(g):
            if not feasible[i, h]:
                continue
            own = w_pref * _turn(axes[i, h], pref[i])
            best = inf
            arg = -1
            for k in range(g):
                c = cost[i - 1, k]
                if c == inf:
                    continue
                if starts[i]:
                    step = 0.0
                else:
                    dot = axes[i, h] @ axes[i - 1, k]
                    if dot < cos_limit[i]:
                        continue
                    step = np.arccos(min(1.0, dot))
                if c + step < best:
                    best = c + step
                    arg = k
            if arg >= 0:
                cost[i, h] = best + own
                back[i, h] = arg
    return cost, back


def shortest_posture(cand: Candidates, s: np.ndarray, preferred: np.ndarray, *,
                     max_turn_per_mm: float, w_pref: float = 0.05,
                     starts: np.ndarray | None = None) -> Posture:
    """Least total turn of the tool axis over the feasible candidates (see the module
    docstring). `s (N,)` path length at each point, mm; `preferred (N, 3)` unit axes;
    `max_turn_per_mm` rad/mm; `starts (N,)` bool rows that begin a new segment. When no chain
    of feasible candidates exists within the turn limit, the path is planned again without the
    limit (the result says so by `method`); points without any feasible
    candidate keep their preferred axis (feasible False)."""
    axes = np.ascontiguousarray(cand.axes, dtype=float)
    feasible = np.asarray(cand.feasible, bool)
    pref = np.ascontiguousarray(preferred, dtype=float)
    n = len(pref)
    starts = np.zeros(n, bool) if starts is None else np.asarray(starts, bool).copy()
    has_any = feasible.any(axis=1)
    # a point without any feasible axis cannot carry the chain: plan around it
    usable = feasible | ~has_any[:, None]
    axes_used = np.where(has_any[:, None, None], axes, pref[:, None, :])
    ds = _steps(s)
    turn = np.where(ds > 0, max_turn_per_mm * np.where(ds > 0, ds, 1.0), 0.0)
    cos_limit = np.cos(np.minimum(turn + 1e-9, np.pi))  # 1e-9 rad: a turn exactly at the limit
    starts = starts | np.r_[True, ~has_any[:-1]] | ~has_any
    method = "shortest path"
    cost, back = _dp(axes_used, usable, pref, w_pref, cos_limit, starts)
    if np.isinf(cost).all(axis=1).any():
        cost, back = _dp(axes_used, usable, pref, w_pref, np.full(n, -2.0), starts)
        method = "shortest path (turn limit exceeded)"
    choice = np.empty(n, np.int64)
    choice[-1] = int(np.argmin(cost[-1]))
    for i in range(n - 1, 0, -1):
        choice[i - 1] = back[i, choice[i]]
    axis = axes_used[np.arange(n), choice]
    return Posture(axis, has_any, method)


def _fair(points: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """One uniform cubic B-spline over the control points `points (N, 3)`, sampled at its knots:
    (P_(i-1) + 4 P_i + P_(i+1)) / 6, the segment ends kept (phantom points 2 P_0 - P_1)."""
    prev = np.vstack([points[:1], points[:-1]])
    nxt = np.vstack([points[1:], points[-1:]])
    ends_before = starts
    ends_after = np.r_[starts[1:], True]
    prev = np.where(ends_before[:, None], 2 * points - nxt, prev)
    nxt = np.where(ends_after[:, None], 2 * points - prev, nxt)
    out = (prev + 4 * points + nxt) / 6.0
    fixed = ends_before | ends_after
    out[fixed] = points[fixed]
    return out


def mb_spline_fairing(planned: Posture, feasible_at: Callable[[np.ndarray, np.ndarray],
                                                              np.ndarray], *,
                      passes: int = 6, starts: np.ndarray | None = None,
                      max_blend_halvings: int = 6) -> Posture:
    """The continuity control of Hwang et al. (2011) on a planned posture: `passes` B-spline
    fairings of the axes' end points (unit length, so the end points are the axes), each followed by
    `feasible_at(rows, axes) -> (K,) bool` on the changed rows; an infeasible faired axis is
    blended back towards the axis before that pass (halving the step up to
    `max_blend_halvings` times, then kept as it was). Every axis of the result is feasible
    wherever the planned one was."""
    axis = np.array(planned.axis, dtype=float)
    n = len(axis)
    starts = np.zeros(n, bool) if starts is None else np.asarray(starts, bool)
    starts = starts.copy()
    starts[0] = True
    ok = np.asarray(planned.feasible, bool)
    for _ in range(passes):
        target = _fair(axis, starts)
        target /= np.linalg.norm(target, axis=1)[:, None]
        todo = np.flatnonzero(ok & (np.abs(target - axis).max(axis=1) > 1e-12))
        step = np.ones(len(todo))
        for _ in range(max_blend_halvings + 1):
            if len(todo) == 0:
                break
            trial = axis[todo] + step[:, None] * (target[todo] - axis[todo])
            trial /= np.linalg.norm(trial, axis=1)[:, None]
            good = np.asarray(feasible_at(todo, trial), bool)
            axis[todo[good]] = trial[good]
            todo, step = todo[~good], step[~good] / 2.0
    return Posture(axis, ok, "MB-spline fairing")


def feasible_regions(cand: Candidates) -> np.ndarray:
    """(N, G) int labels of the connected feasible regions of each point's (lead, tilt) grid
    (4-connected, 0 = infeasible); labels are unique over all points."""
    n = len(cand.feasible)
    mask = np.asarray(cand.feasible, bool).reshape(n, *cand.grid)
    structure = np.zeros((3, 3, 3), bool)
    structure[1] = ndimage.generate_binary_structure(2, 1)
    labels, _ = ndimage.label(mask, structure=structure)
    return labels.reshape(n, -1)


def _local_optima(cand: Candidates) -> tuple[np.ndarray, np.ndarray]:
    """Each feasible region's best-scored candidate: `(optima (N, K) int, count (N,))`, K the
    most regions of any point; padded with -1."""
    labels = feasible_regions(cand)
    n, g = labels.shape
    flat = labels.ravel()
    ids = np.unique(flat[flat > 0])
    if len(ids) == 0:
        return np.full((n, 1), -1, np.int64), np.zeros(n, np.int64)
    best = ndimage.maximum_position(np.asarray(cand.score, float).ravel(), flat, ids)
    best = np.array([b[0] for b in best], np.int64)
    row = best // g
    count = np.bincount(row, minlength=n)
    k = max(int(count.max()), 1)
    optima = np.full((n, k), -1, np.int64)
    order = np.argsort(row, kind="stable")
    slot = np.arange(len(best)) - np.repeat(np.cumsum(count) - count, count)
    optima[row[order], slot] = best[order] % g
    return optima, count


@njit(cache=True)
def _greedy(axes, optima, count, fallback, first, backward):  # pragma: no cover - compiled
    n = axes.shape[0]
    out = np.empty((n, 3))
    total = 0.0
    rng = range(n - 1, -1, -1) if backward else range(n)
    prev = np.empty(3)
    started = False
    for i in rng:
        if count[i] == 0:
            out[i] = fallback[i]
            continue
        if not started:
            out[i] = axes[i, first[i]]
            started = True
        else:
            best = np.inf
            for k in range(count[i]):
                c = _turn(axes[i, optima[i, k]], prev)
                if c < best:
                    best = c
                    out[i] = axes[i, optima[i, k]]
            total += best
        prev[:] = out[i]
    return out, total


def greedy_smoothing(cand: Candidates, preferred: np.ndarray) -> Posture:
    """Algorithm II of Jun, Lee and Cha (2002) (see the module docstring): the C-distance is the
    turn between the unit axes (the paper's Euclidean distance in (α, β) is the same to first order
    and does not depend on the local frame). Points without a feasible axis keep `preferred`."""
    optima, count = _local_optima(cand)
    axes = np.ascontiguousarray(cand.axes, dtype=float)
    score = np.asarray(cand.score, float)
    n = len(axes)
    safe = np.where(optima >= 0, optima, 0)
    opt_score = np.where(optima >= 0, score[np.arange(n)[:, None], safe], -np.inf)
    first = safe[np.arange(n), np.argmax(opt_score, axis=1)]
    pref = np.ascontiguousarray(preferred, dtype=float)
    fwd, c_fwd = _greedy(axes, safe, count, pref, first, False)
    bwd, c_bwd = _greedy(axes, safe, count, pref, first, True)
    axis = fwd if c_fwd <= c_bwd else bwd
    return Posture(axis, count > 0, "greedy smoothing (Jun, Lee and Cha)")


class PostureMetrics(NamedTuple):
    """Along the path, over the machine's rotary angles (degrees): the total motion
    sum |Δ| over both axes, the largest angular velocity |Δ/Δs| (deg/mm) and the largest
    angular acceleration |Δ(Δ/Δs)/Δs| (deg/mm²); segment starts are not crossed."""

    total_motion_deg: float
    peak_velocity_deg_per_mm: float
    peak_acceleration_deg_per_mm2: float


def posture_metrics(angles: np.ndarray, s: np.ndarray,
                    starts: np.ndarray | None = None) -> PostureMetrics:
    """`angles (N, k)` degrees (the machine's rotary words, or any angles of the axis),
    `s (N,)` path length, mm; `starts (N,)` rows that begin a new segment."""
    a = np.asarray(angles, float).reshape(len(angles), -1)
    s = np.asarray(s, float)
    n = len(a)
    starts = np.zeros(n, bool) if starts is None else np.asarray(starts, bool)
    ds = np.diff(s)
    da = np.abs(np.diff(a, axis=0))
    keep = ~starts[1:] & (ds > 1e-9)
    total = float(da[~starts[1:]].sum())
    vel = np.where(keep[:, None], np.diff(a, axis=0) / np.where(keep, ds, 1.0)[:, None], np.nan)
    mid = 0.5 * (ds[1:] + ds[:-1]) if n > 2 else np.zeros(0)
    both = keep[1:] & keep[:-1] if n > 2 else np.zeros(0, bool)
    acc = np.where(both[:, None], np.diff(vel, axis=0) / np.where(both, mid, 1.0)[:, None],
                   np.nan)
    peak_v = float(np.nanmax(np.abs(vel))) if np.isfinite(vel).any() else 0.0
    peak_a = float(np.nanmax(np.abs(acc))) if np.isfinite(acc).any() else 0.0
    return PostureMetrics(total, peak_v, peak_a)
