"""Cheap bounds of a triangle's signed value against a tool's piece P = K (+) rho B (tool frame,
mm; `checker.mesh.core`): signed = rho - min over x in T of sd_K(x), the depth of T in P when
positive, minus the clearance otherwise. Upper bounds: the sides' constraints,
rho + min_i (c_i - min over T of a_i r + b_i h), with min r over T the distance from the axis to
T's shadow along it (or, cheaper, to the box of that shadow); and T's plane against K's support
function. Lower bound: the exact value at T's point nearest the axis. The branch and bound of a
pose (`checker.mesh.pose`) examines a triangle exactly only when its upper bound beats the best
value so far. (docs/MATH.md §8)"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.mesh.core import signed_distance
from checker.mesh.nearest import edge_weights


class Bound(NamedTuple):
    """A triangle's `upper` bound of its signed value (mm), the `erosion` bound (the upper
    bound of the depth t* at which K (-) t* B still meets it) and its `point` whose shadow is
    nearest the axis (tool frame)."""

    upper: float
    erosion: float
    point: tuple[float, float, float]


@nb.njit(cache=True, _nrt=False)
def plane_upper(T, n, core):
    """Upper bound of the signed value of triangle T (unit normal `n`, 3-tuple, tool frame)
    from its plane: rho - max(d+, d-), d+- the distances by which the core K lies beyond the
    plane on either side (support function h_K): dist(T, K) >= d+- when positive, and where
    the plane cuts K, K (-) tB meets it only while t <= -d+ and t <= -d- (h_(K (-) tB) <=
    h_K - t)."""
    nx, ny, nz = n
    P = core.profile
    s = math.sqrt(nx * nx + ny * ny)
    hp = -np.inf
    hm = -np.inf
    for k in range(core.count):
        hp = max(hp, s * P[k, 0] + nz * P[k, 1])
        hm = max(hm, s * P[k, 0] - nz * P[k, 1])
    c = nx * T[0, 0] + ny * T[0, 1] + nz * T[0, 2]
    return core.rho - max(-hm - c, c - hp)


@nb.njit(cache=True, forceinline=True)
def _slack(T, core, rmin):
    """min_i (c_i - min over T of (a_i r + b_i h)) with T's least distance `rmin` from the axis
    (a degenerate core: the bounding cylinder's sides, at most 0), mm. T: the vertices of a
    triangle, or of any convex polytope (rows)."""
    hmin, hmax = T[0, 2], T[0, 2]
    for k in range(1, T.shape[0]):
        hmin, hmax = min(hmin, T[k, 2]), max(hmax, T[k, 2])
    if core.solid:
        ub = np.inf
        for i in range(core.sides):
            a, b = core.normal[i, 0], core.normal[i, 1]
            fmin = a * rmin + (b * hmin if b >= 0.0 else b * hmax)
            ub = min(ub, core.offset[i] - fmin)
        return ub
    return min(0.0, min(core.rmax - rmin, min(hmax - core.hlo, core.hhi - hmin)))


@nb.njit(cache=True, _nrt=False)
def quick_upper(T, core):
    """A cheaper, looser `upper_bound`: min r over T bounded below by the distance from the axis
    to the box of T's shadow (T: a triangle's vertices, or any convex polytope's)."""
    x0, x1, y0, y1 = T[0, 0], T[0, 0], T[0, 1], T[0, 1]
    for k in range(1, T.shape[0]):
        x0, x1 = min(x0, T[k, 0]), max(x1, T[k, 0])
        y0, y1 = min(y0, T[k, 1]), max(y1, T[k, 1])
    dx = max(x0, max(-x1, 0.0))
    dy = max(y0, max(-y1, 0.0))
    rmin = math.sqrt(dx * dx + dy * dy)
    return core.rho + _slack(T, core, rmin)


@nb.njit(cache=True, _nrt=False)
def shadow_weights(T):
    """Weights (u, v, w) of a point of triangle T (tool frame) whose shadow along the axis is
    nearest the axis, and whether the axis meets the shadow (the three edges see it on one
    side; then the weights are its barycentric ones), else the nearest point of the nearest
    edge. Robust for slivers (a wall seen edge-on, whose shadow is a segment to rounding):
    Ericson's regions (`nearest.triangle_weights`) decide from differences of products that
    rounding swamps there, which put the point 2 mm from the axis where the shadow crosses it;
    here a sliver the axis meets to rounding is met (its weights may then be anywhere on T),
    and one it misses to rounding has an edge within rounding of the axis."""
    ax, ay, bx, by, cx, cy = T[0, 0], T[0, 1], T[1, 0], T[1, 1], T[2, 0], T[2, 1]
    wa = bx * cy - by * cx  # twice the signed areas of (axis, b, c), (axis, c, a), (axis, a, b)
    wb = cx * ay - cy * ax
    wc = ax * by - ay * bx
    total = wa + wb + wc
    if total != 0.0 and ((wa >= 0.0 and wb >= 0.0 and wc >= 0.0)
                         or (wa <= 0.0 and wb <= 0.0 and wc <= 0.0)):
        return wa / total, wb / total, wc / total, True
    u, v, w = edge_weights(ax, ay, 0.0, bx, by, 0.0, cx, cy, 0.0)
    return u, v, w, False


@nb.njit(cache=True, _nrt=False)
def upper_bound(T, core):
    """The `Bound` of triangle T (tool frame): rho + min_i (c_i - min over T of (a_i r + b_i h)),
    with min r = the distance from the axis to T's shadow along it (a degenerate core: the
    bounding cylinder's sides, at most 0)."""
    u, v, w, met = shadow_weights(T)
    xx = u * T[0, 0] + v * T[1, 0] + w * T[2, 0]
    xy = u * T[0, 1] + v * T[1, 1] + w * T[2, 1]
    rmin = 0.0 if met else math.sqrt(xx * xx + xy * xy)
    ub = _slack(T, core, rmin)
    return Bound(core.rho + ub, ub, (xx, xy, u * T[0, 2] + v * T[1, 2] + w * T[2, 2]))


@nb.njit(cache=True)
def lower_bound(core, upper, point):
    """Lower bound of a triangle's signed value: the exact value at its `point` nearest the axis
    (`Bound.point`; exact for a floor under a flat bottom), at most its `upper` bound."""
    x0, y0, z0 = point
    sd, _, _ = signed_distance(core, core.profile, core.count, 0.0,
                               math.sqrt(x0 * x0 + y0 * y0), z0)
    return min(core.rho - sd, upper)
