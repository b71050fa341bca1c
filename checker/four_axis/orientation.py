"""Choosing the table angle B along a path inside each point's feasible set.

Two methods, reported side by side:
- `shortest_path_orientation`: dynamic programming over a B grid (plus the interval optima and the
  CAM's original angles as extra candidates). Cost = `w_change * |dB|` between consecutive points
  + `w_original * |B - B_original|`, with the machine's B limits and at most `max_db_per_mm * ds`
  degrees of change over a path step of length ds. The transition minimum is an L1 distance
  transform over a sliding window (monotone deques), so a step costs O(K), not O(K^2).
- `greedy_smoothing`: Jun, Lee and Cha (2002), Algorithm II: forward smoothing from the first
  point's optimum and backward smoothing from the last point's, each step taking the local optimum
  (one per feasible interval) nearest to the previous choice; the pass with the smaller total
  C-distance wins.

A point with no feasible B is flagged (`feasible = False`) and never dropped: it keeps a B (its
best B for the greedy pass; for the shortest path, any B, pulled towards its best B).
Angles in degrees; path lengths in mm.
(docs/MATH.md §7.2)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from checker.four_axis.intervals import Intervals


@dataclass(frozen=True)
class Orientation:
    """B per point (degrees), its total rotary motion sum |dB| (degrees), the points that had a
    feasible B, and the method that chose it."""

    b: np.ndarray
    total_rotation: float
    feasible: np.ndarray
    method: str


def total_rotation(b: np.ndarray) -> float:
    """Sum of |dB| along the path, degrees."""
    return float(np.abs(np.diff(np.asarray(b, dtype=float))).sum())


def interval_optima(
    b_grid: np.ndarray, allowable: np.ndarray, intervals: list[Intervals]
) -> list[np.ndarray]:
    """Local optimum of each feasible interval: the grid B of the largest allowable size inside
    the interval (its midpoint when no grid sample falls inside). One array per point."""
    b_grid = np.asarray(b_grid, dtype=float)
    out = []
    for row, ivs in enumerate(intervals):
        best = np.empty(len(ivs))
        for j, (lo, hi) in enumerate(ivs):
            inside = (b_grid >= lo) & (b_grid <= hi)
            if inside.any():
                values = np.where(inside, allowable[row], -np.inf)
                best[j] = b_grid[int(np.argmax(values))]
            else:
                best[j] = 0.5 * (lo + hi)
        out.append(best)
    return out


@njit(cache=True)
def _nearest_pass(cand_values, cand_ptr, order, start):
    """Greedy pass in the given point order: take the candidate nearest to the previous choice."""
    n = order.shape[0]
    chosen = np.empty(n)
    chosen[order[0]] = start
    prev = start
    total = 0.0
    for step in range(1, n):
        i = order[step]
        best = cand_values[cand_ptr[i]]
        best_d = abs(best - prev)
        for j in range(cand_ptr[i] + 1, cand_ptr[i + 1]):
            d = abs(cand_values[j] - prev)
            if d < best_d:
                best_d = d
                best = cand_values[j]
        chosen[i] = best
        total += best_d
        prev = best
    return chosen, total


def _nearest(values: np.ndarray, b: float) -> float:
    return float(values[np.argmin(np.abs(values - b))])


def greedy_smoothing(
    optima: list[np.ndarray], b_best: np.ndarray
) -> tuple[Orientation, Orientation]:
    """Jun, Lee and Cha (2002), Algorithm II. `optima[i]`: local optima of point i's feasible
    intervals (empty: infeasible, then its best B stands in). `b_best`: (N,) best B per point, the
    starting choices. Returns (winner, loser) of the forward and backward passes."""
    b_best = np.asarray(b_best, dtype=float)
    feasible = np.array([len(o) > 0 for o in optima], dtype=bool)
    lists = [o if len(o) else np.array([b_best[i]]) for i, o in enumerate(optima)]
    values = np.concatenate(lists).astype(float)
    ptr = np.zeros(len(lists) + 1, dtype=np.int64)
    ptr[1:] = np.cumsum([len(v) for v in lists])
    n = len(lists)
    forward_start = _nearest(lists[0], b_best[0])
    backward_start = _nearest(lists[-1], b_best[-1])
    fwd_b, fwd_total = _nearest_pass(values, ptr, np.arange(n), forward_start)
    bwd_b, bwd_total = _nearest_pass(values, ptr, np.arange(n)[::-1].copy(), backward_start)
    fwd = Orientation(fwd_b, float(fwd_total), feasible, "greedy-forward")
    bwd = Orientation(bwd_b, float(bwd_total), feasible, "greedy-backward")
    return (fwd, bwd) if fwd_total <= bwd_total else (bwd, fwd)


@njit(cache=True)
def _window_min(values, grid, width, direction):
    """For each k, min and argmin of values[k'] over k' with 0 <= direction*(grid[k]-grid[k']) <=
    width (direction +1: window to the left of k, -1: to the right). Monotone deque, O(K)."""
    k_count = values.shape[0]
    out = np.full(k_count, np.inf)
    arg = np.full(k_count, -1, dtype=np.int64)
    dq = np.empty(k_count, dtype=np.int64)
    head = 0
    tail = 0
    for step in range(k_count):
        k = step if direction > 0 else k_count - 1 - step
        while tail > head and values[dq[tail - 1]] >= values[k]:
            tail -= 1
        dq[tail] = k
        tail += 1
        while tail > head and direction * (grid[k] - grid[dq[head]]) > width:
            head += 1
        if tail > head:
            out[k] = values[dq[head]]
            arg[k] = dq[head]
    return out, arg


@njit(cache=True, forceinline=True)
def _unary(allowed, target, w_original, grid, i, k):
    """Cost of point i at candidate k: w_original*|B - target| where allowed, else inf (computed
    where needed: the (n, K) matrix would be the largest array of the job)."""
    return w_original * np.abs(grid[k] - target[i]) if allowed[i, k] else np.inf


@njit(cache=True)
def _shortest_path(grid, allowed, target, w_original, widths, w_change):
    """Viterbi over the candidate grid; transition cost w_change*|dB|, |dB| <= widths[i]; the
    unary cost `_unary`."""
    n, k_count = allowed.shape
    back = np.empty((n, k_count), dtype=np.int32)
    cost = np.empty(k_count)
    for k in range(k_count):
        cost[k] = _unary(allowed, target, w_original, grid, 0, k)
    for i in range(1, n):
        left, left_arg = _window_min(cost - w_change * grid, grid, widths[i], 1)
        right, right_arg = _window_min(cost + w_change * grid, grid, widths[i], -1)
        new = np.empty(k_count)
        for k in range(k_count):
            a = left[k] + w_change * grid[k]
            b = right[k] - w_change * grid[k]
            if a <= b:
                new[k] = a + _unary(allowed, target, w_original, grid, i, k)
                back[i, k] = left_arg[k]
            else:
                new[k] = b + _unary(allowed, target, w_original, grid, i, k)
                back[i, k] = right_arg[k]
        cost = new
    path = np.empty(n, dtype=np.int64)
    path[n - 1] = np.argmin(cost)
    final = cost[path[n - 1]]
    for i in range(n - 1, 0, -1):
        path[i - 1] = back[i, path[i]]
    return path, final


def shortest_path_orientation(
    intervals: list[Intervals],
    b_original: np.ndarray,
    b_best: np.ndarray,
    path_length: np.ndarray,
    *,
    b_min: float,
    b_max: float,
    grid_step: float,
    w_change: float,
    w_original: float,
    max_db_per_mm: float | None,
    extra_candidates: np.ndarray | None = None,
) -> Orientation:
    """B per point minimising w_change*sum|dB| + w_original*sum|B - B_original| inside the feasible
    intervals. `b_original` may hold nan (no CAM orientation: the best B stands in). `path_length`:
    (N,) length of the step arriving at each point, mm (first entry unused). Infeasible points may
    take any B in [b_min, b_max], pulled towards their best B. When the rate limit makes the path
    impossible it is relaxed (method ends in "+relaxed")."""
    n = len(intervals)
    b_best = np.asarray(b_best, dtype=float)
    feasible = np.array([len(iv) > 0 for iv in intervals], dtype=bool)
    target = np.where(np.isfinite(b_original) & feasible, b_original, b_best)
    grid = np.arange(b_min, b_max + 0.5 * grid_step, grid_step)
    pieces = [grid, np.clip(target, b_min, b_max), np.clip(b_best, b_min, b_max)]
    if extra_candidates is not None and len(extra_candidates):
        pieces.append(np.clip(np.asarray(extra_candidates, dtype=float), b_min, b_max))
    grid = np.unique(np.concatenate(pieces))
    allowed = np.zeros((n, grid.size), dtype=bool)
    for i, ivs in enumerate(intervals):
        if not ivs:
            allowed[i] = True
        for lo, hi in ivs:
            allowed[i] |= (grid >= lo - 1e-9) & (grid <= hi + 1e-9)
    widths = np.full(n, np.inf)
    if max_db_per_mm is not None:
        widths = max_db_per_mm * np.asarray(path_length, dtype=float)
    method = "shortest-path"
    unary = (allowed, target, float(w_original))  # `_unary`, computed where needed
    path, final = _shortest_path(grid, *unary, widths, float(w_change))
    if not np.isfinite(final):
        path, final = _shortest_path(grid, *unary, np.full(n, np.inf), float(w_change))
        method += "+relaxed"
    b = grid[path]
    return Orientation(b, total_rotation(b), feasible, method)
