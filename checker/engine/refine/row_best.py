"""The answer of each CC row so far: the smallest size found and where it lies. The scan's sampled
minimum starts it (`sampled`); the refined starts, the limits at the CC point and the walk along
the contour each lower it where they find less (`RowBest.lower`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.geometry.sampling import TestPoints


class RowBest(NamedTuple):
    """Per row (N,): the smallest `size` found (mm, inf: none), its `point (N, 3)` (part frame,
    nan: none), `surface` (-1: none) and `uv (N, 2)` (nan: none), and the `evaluations` of the
    imaginary size spent. The arrays change in place."""

    size: np.ndarray
    point: np.ndarray
    surface: np.ndarray
    uv: np.ndarray
    evaluations: np.ndarray

    def lower(self, rows: np.ndarray, size: np.ndarray, point: np.ndarray, surface: np.ndarray,
              uv: np.ndarray) -> None:
        """Per row, the smallest of the candidates (rows (K,), size, point, surface, uv)
        replaces the row's best where it is smaller (in place)."""
        order = np.lexsort((size, rows))
        first = np.ones(order.size, dtype=bool)
        first[1:] = rows[order][1:] != rows[order][:-1]
        pick = order[first]
        r = rows[pick]
        better = size[pick] < self.size[r]
        r, pick = r[better], pick[better]
        self.size[r], self.point[r], self.surface[r], self.uv[r] = (size[pick], point[pick],
                                                                    surface[pick], uv[pick])


def sampled(tp: TestPoints, size: np.ndarray, arg: np.ndarray,
            evaluations: np.ndarray) -> RowBest:
    """The rows' best at their sampled minima: `size (N,)` at the test points `arg (N,)` (-1:
    none)."""
    n = len(size)
    has = arg >= 0
    point = np.full((n, 3), np.nan)
    point[has] = tp.points[arg[has]]
    surface = np.where(has, tp.surface[np.maximum(arg, 0)], -1).astype(np.int64)
    uv = np.full((n, 2), np.nan)
    uv[has] = tp.uv[arg[has]]
    return RowBest(size.copy(), point, surface, uv, evaluations)
