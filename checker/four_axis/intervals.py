"""Feasible B sets as intervals, from the allowable size sampled over a B grid.

The feasible set of a CC point for the real cutter is {B : allowable(B) >= size + tol}
(docs/MATH.md §7.1). Given allowable sizes on a sorted B grid, the set is a union of intervals
whose ends are found by linear interpolation of the crossing between two grid samples (or
refined by the caller). Angles in degrees.
"""

from __future__ import annotations

import numpy as np

Intervals = list[tuple[float, float]]


def crossing(b0: np.ndarray, b1: np.ndarray, a0: np.ndarray, a1: np.ndarray, level: np.ndarray):
    """B where the straight line through (b0, a0), (b1, a1) reaches `level`; infinite sizes are
    treated as far above the level (the crossing then sits at the finite end)."""
    a0 = np.where(np.isfinite(a0), a0, level + 1e6)
    a1 = np.where(np.isfinite(a1), a1, level + 1e6)
    span = a1 - a0
    t = np.divide(level - a0, span, out=np.full_like(span, 0.5), where=np.abs(span) > 1e-300)
    return b0 + np.clip(t, 0.0, 1.0) * (b1 - b0)


def feasible_intervals(
    b_grid: np.ndarray, allowable: np.ndarray, required: float | np.ndarray
) -> list[Intervals]:
    """Feasible intervals per point.

    b_grid: (K,) increasing B values, degrees. allowable: (N, K) allowable sizes, mm (inf allowed).
    required: scalar or (N,) size the real cutter needs (size + tolerance), mm.
    Returns for each of the N points a list of (lo, hi) intervals, degrees (empty: no feasible B).
    """
    b_grid = np.asarray(b_grid, dtype=float)
    allowable = np.atleast_2d(np.asarray(allowable, dtype=float))
    n, k = allowable.shape
    level = np.broadcast_to(np.asarray(required, dtype=float), (n,))
    ok = allowable >= level[:, None]
    padded = np.zeros((n, k + 2), dtype=np.int8)
    padded[:, 1:-1] = ok
    step = np.diff(padded, axis=1)  # +1 where a run starts at column j, -1 where it ended before j
    rows_s, cols_s = np.nonzero(step == 1)
    rows_e, cols_e = np.nonzero(step == -1)
    cols_e = cols_e - 1  # last feasible column of each run
    lo = b_grid[cols_s].copy()
    inner = cols_s > 0
    lo[inner] = crossing(
        b_grid[cols_s[inner] - 1], b_grid[cols_s[inner]],
        allowable[rows_s[inner], cols_s[inner] - 1], allowable[rows_s[inner], cols_s[inner]],
        level[rows_s[inner]],
    )
    hi = b_grid[cols_e].copy()
    inner = cols_e < k - 1
    hi[inner] = crossing(
        b_grid[cols_e[inner]], b_grid[cols_e[inner] + 1],
        allowable[rows_e[inner], cols_e[inner]], allowable[rows_e[inner], cols_e[inner] + 1],
        level[rows_e[inner]],
    )
    out: list[Intervals] = [[] for _ in range(n)]
    for row, a, b in zip(rows_s.tolist(), lo.tolist(), hi.tolist(), strict=True):
        out[row].append((a, b))
    return out


def contains(intervals: Intervals, b: float, slack: float = 1e-9) -> bool:
    """Whether B (degrees) lies in one of the intervals."""
    return any(lo - slack <= b <= hi + slack for lo, hi in intervals)
