"""The triangles a pose's branch and bound keeps for exact evaluation (`checker.mesh.pose`):
each with its upper bound, its point nearest the tool's axis and its vertices in the tool frame
(mm), taken best bound first."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np


class Candidates(NamedTuple):
    """Rows of kept triangles (a buffer: rows past the count kept unused): `index (n,)` the
    triangle (tree order), `upper (n,)` the upper bound of its signed value (mm), `point
    (n, 3)` its point whose shadow is nearest the axis and `triangle (n, 3, 3)` its vertices,
    tool frame."""

    index: np.ndarray
    upper: np.ndarray
    point: np.ndarray
    triangle: np.ndarray


@nb.njit(cache=True)
def new_candidates(n):
    """Empty `Candidates` of n rows."""
    return Candidates(np.empty(n, dtype=np.int64), np.empty(n), np.empty((n, 3)),
                      np.empty((n, 3, 3)))


@nb.njit(cache=True, _nrt=False)
def keep(c, k, t, upper, point, T):
    """Row k of `c`: triangle t (tree order) with its `upper` bound and `point` (3-tuple), its
    vertices T (3, 3)."""
    c.index[k] = t
    c.upper[k] = upper
    c.point[k, 0], c.point[k, 1], c.point[k, 2] = point
    for v in range(3):
        c.triangle[k, v, 0] = T[v, 0]
        c.triangle[k, v, 1] = T[v, 1]
        c.triangle[k, v, 2] = T[v, 2]


@nb.njit(cache=True, _nrt=False)
def best_left(c, n):
    """The row of the largest upper bound among the first n (the first of equals)."""
    jb = 0
    ub = c.upper[0]
    for j in range(1, n):
        if c.upper[j] > ub:
            ub, jb = c.upper[j], j
    return jb


@nb.njit(cache=True, _nrt=False)
def take(c, j, last, T):
    """Row j's vertices into T (3, 3); row `last` moves into row j. Returns row j's triangle
    index and point."""
    t = c.index[j]
    point = (c.point[j, 0], c.point[j, 1], c.point[j, 2])
    for v in range(3):
        T[v, 0], T[v, 1], T[v, 2] = c.triangle[j, v, 0], c.triangle[j, v, 1], c.triangle[j, v, 2]
    if j != last:
        c.index[j] = c.index[last]
        c.upper[j] = c.upper[last]
        for a in range(3):
            c.point[j, a] = c.point[last, a]
            for v in range(3):
                c.triangle[j, v, a] = c.triangle[last, v, a]
    return t, point
