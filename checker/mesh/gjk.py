"""The distance between a convex polytope (a triangle, a prism: its vertices, tool frame, mm)
and a convex solid of revolution (the core K of a tool's piece, `checker.mesh.core`), by GJK
(Gilbert, Johnson and Keerthi 1988; the simplex steps of `checker.mesh.nearest`). The polytope's
support is its best vertex; K's is the best profile vertex swung towards the direction: for a
direction (dx, dy, dz), s = |(dx, dy)|, the vertex maximising s r_j + dz h_j, at
(r_j dx/s, r_j dy/s, h_j). Every step certifies a lower bound (the support's gap) and an upper
bound (the simplex's nearest point) of the distance. Near a contact with a curved rim GJK
converges slowly and may not certify a separation (`UNCERTIFIED`). The certificate of a whole
stretch of a move asks it (`checker.mesh.swept`, docs/MATH.md §8.1)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.mesh.nearest import segment_weights, tetrahedron_weights, triangle_weights

GJK_EPS = 1e-11     # mm: GJK stops when its upper and lower distance bounds are this close
GJK_TOUCH = 1e-10   # mm: a distance below this counts as touching
GJK_ITER = 100
# `Distance.status`: separated (0 < lower <= distance <= upper); intersecting or closer than
# GJK_TOUCH (lower = upper = 0); farther than the threshold asked (lower > it); stopped by
# rounding or the iteration limit with no positive lower bound (0 <= distance <= upper,
# intersection not excluded)
SEPARATED, TOUCHING, FARTHER, UNCERTIFIED = range(4)


class Simplex(NamedTuple):
    """GJK's scratch: the simplex's vertices `w (4, 3)` (differences of a polytope point and a
    solid point), their polytope points `a (4, 3)` and weights `lam (12,)` (rows 4-11 scratch)."""

    w: np.ndarray
    a: np.ndarray
    lam: np.ndarray


class Distance(NamedTuple):
    """GJK's answer: `status` (SEPARATED, TOUCHING, FARTHER, UNCERTIFIED), the distance's
    certified bounds `lower`..`upper` (mm) and the polytope's `point` nearest the solid (a
    common point when they meet; tool frame)."""

    status: int
    lower: float
    upper: float
    point: tuple[float, float, float]


@nb.njit(cache=True)
def simplex_buffers():
    """An empty `Simplex` (one per thread)."""
    return Simplex(np.empty((4, 3)), np.empty((4, 3)), np.empty(12))


@nb.njit(cache=True)
def support(P, m, dx, dy, dz):
    """Support point of the solid of revolution of P[:m] in direction (dx, dy, dz)."""
    s = math.sqrt(dx * dx + dy * dy)
    j = 0
    best = -np.inf
    for k in range(m):
        v = s * P[k, 0] + dz * P[k, 1]
        if v > best:
            best, j = v, k
    r = P[j, 0]
    if s > 0.0:
        return r * dx / s, r * dy / s, P[j, 1]
    return r, 0.0, P[j, 1]


@nb.njit(cache=True)
def _reduce(W, A, lam, n):
    """Nearest point v of the simplex W[:n] to the origin; keep the vertices that support it
    (W, A, lam compacted). Returns (n, vx, vy, vz, inside)."""
    inside = False
    if n == 1:
        lam[0] = 1.0
    elif n == 2:
        lam[0], lam[1] = segment_weights(W[0, 0], W[0, 1], W[0, 2], W[1, 0], W[1, 1], W[1, 2])
    elif n == 3:
        lam[0], lam[1], lam[2] = triangle_weights(W[0, 0], W[0, 1], W[0, 2], W[1, 0], W[1, 1],
                                                  W[1, 2], W[2, 0], W[2, 1], W[2, 2])
    else:
        inside = tetrahedron_weights(W, lam)
    vx = vy = vz = 0.0
    for k in range(n):
        vx += lam[k] * W[k, 0]
        vy += lam[k] * W[k, 1]
        vz += lam[k] * W[k, 2]
    if inside:
        return n, 0.0, 0.0, 0.0, True
    q = 0
    for k in range(n):
        if lam[k] > 0.0:
            if q != k:
                for a in range(3):
                    W[q, a] = W[k, a]
                    A[q, a] = A[k, a]
                lam[q] = lam[k]
            q += 1
    if q == 0:
        q = 1
        lam[0] = 1.0
    return q, vx, vy, vz, False


@nb.njit(cache=True)
def gjk_distance(T, P, m, thresh, x0, y0, simplex):
    """The `Distance` between the triangle T (3, 3) (or any convex polytope: its vertices
    (k, 3)) and the solid of revolution of the profile P[:m] (tool frame, mm), starting from the
    points x0 in T and y0 in the solid (3-tuples); stops early once the distance is certified
    above `thresh`. `simplex`: a `Simplex` scratch."""
    W, A, lam = simplex
    x0x, x0y, x0z = x0
    y0x, y0y, y0z = y0
    W[0, 0], W[0, 1], W[0, 2] = x0x - y0x, x0y - y0y, x0z - y0z
    A[0, 0], A[0, 1], A[0, 2] = x0x, x0y, x0z
    lam[0] = 1.0
    n = 1
    vx, vy, vz = W[0, 0], W[0, 1], W[0, 2]
    lb = 0.0
    status = SEPARATED
    lower = upper = 0.0
    for _ in range(GJK_ITER):
        vv = vx * vx + vy * vy + vz * vz
        if vv <= GJK_TOUCH * GJK_TOUCH:
            status = TOUCHING  # touching within GJK_TOUCH: counted as meeting
            break
        vn = math.sqrt(vv)
        j = 0
        dmin = vx * T[0, 0] + vy * T[0, 1] + vz * T[0, 2]
        for k in range(1, T.shape[0]):
            d = vx * T[k, 0] + vy * T[k, 1] + vz * T[k, 2]
            if d < dmin:
                dmin, j = d, k
        bx, by, bz = support(P, m, vx, vy, vz)
        wx, wy, wz = T[j, 0] - bx, T[j, 1] - by, T[j, 2] - bz
        vw = vx * wx + vy * wy + vz * wz
        if vw > lb * vn:
            lb = vw / vn
        if lb > thresh:
            lower, upper = lb, vn
            status = FARTHER
            break
        if vn - lb <= GJK_EPS + 1e-13 * vn:
            break
        dup = False
        for k in range(n):
            if W[k, 0] == wx and W[k, 1] == wy and W[k, 2] == wz:
                dup = True
        if dup:
            break
        W[n, 0], W[n, 1], W[n, 2] = wx, wy, wz
        A[n, 0], A[n, 1], A[n, 2] = T[j, 0], T[j, 1], T[j, 2]
        n += 1
        n, nx_, ny_, nz_, inside = _reduce(W, A, lam, n)
        if inside:
            if lb > GJK_TOUCH:
                break       # contradicts the certified lower bound: rounding; keep v
            status = TOUCHING
            break
        if nx_ * nx_ + ny_ * ny_ + nz_ * nz_ >= vv:
            break   # no progress: rounding
        vx, vy, vz = nx_, ny_, nz_
    px = py = pz = 0.0
    for k in range(n):
        px += lam[k] * A[k, 0]
        py += lam[k] * A[k, 1]
        pz += lam[k] * A[k, 2]
    if status == TOUCHING:
        lower, upper = 0.0, 0.0
    elif status == SEPARATED:
        lower, upper = lb, math.sqrt(vx * vx + vy * vy + vz * vz)
        if lb <= 0.0:
            status = UNCERTIFIED
    return Distance(status, lower, upper, (px, py, pz))
