"""The exact signed value of a triangle against a tool's piece P = K (+) rho B (tool frame, mm;
`checker.mesh.core`): rho - min over x in T of sd_K(x), sd_K the signed distance to the core K,
by a one-dimensional convex minimisation over T's horizontal slices (docs/MATH.md §8).

sd_K(x) = sd2(r(x), h(x)), sd2 the signed distance in the profile plane to the mirrored (convex)
profile, convex and even in r, hence nondecreasing in r >= 0. On the slice of T at height h the
minimum is therefore at the slice's point nearest the axis, r = m(h), m convex (a partial
minimum of the convex r over a convex set), so phi(h) = sd2(m(h), h) is a convex function of one
variable; its minimum over T's heights is bracketed by tangent lines with guaranteed subgradient
intervals, to SLICE_EPS."""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.mesh.core import signed_distance_gradient

SLICE_EPS = 1e-10   # mm: the minimisation stops when its bounds are this close
BRACKETS = 64       # brackets held at once, at most
# columns of a bracket (a row of `br`): its ends a and b (levels), phi and the slope at each
# (the slope at a valid to its right, at b to its left), probes that did not halve it, the
# next step (0 the tangents' meeting, 1 the secant), the end replaced last (-1 a, +1 b) and the
# Illinois scales of the slopes at a and b
_A, _FA, _GA, _B, _FB, _GB, _STALLS, _SECANT, _LAST, _SCALE_A, _SCALE_B = range(11)
BRACKET_COLUMNS = 11


class SliceValue(NamedTuple):
    """phi at one level (mm), an interval `slope_lo`..`slope_hi` holding its subgradients, and
    the slice's point nearest the axis (tool frame)."""

    value: float
    slope_lo: float
    slope_hi: float
    point: tuple[float, float, float]


@nb.njit(cache=True)
def _slice_at(T, order, s1, s, core):
    """The `SliceValue` at level s: phi(s) = signed distance to K of the point nearest the axis
    on the slice of T at level s (s = 0 at vertex order[0], s1 at order[1], 1 at order[2];
    heights affine in s), an interval that contains the subdifferential of phi at s, and that
    point.

    m(s), the slice's distance from the axis, has the derivative u . (E' + w D') (Danskin; u the
    unit direction to the nearest point E + w D of the slice E..F, D = F - E); where the slice
    is short (a vertex) its nearest point is any of it: the interval spans w = 0 and w = 1;
    where m is about 0 it is [-C, C], C the Lipschitz constant of m."""
    i0, i1, i2 = order
    ex = T[i0, 0] + s * (T[i2, 0] - T[i0, 0])
    ey = T[i0, 1] + s * (T[i2, 1] - T[i0, 1])
    dex, dey = T[i2, 0] - T[i0, 0], T[i2, 1] - T[i0, 1]
    if (s <= s1 and s1 > 0.0) or s1 >= 1.0:
        u = min(1.0, s / s1) if s1 > 0.0 else 0.0
        fx = T[i0, 0] + u * (T[i1, 0] - T[i0, 0])
        fy = T[i0, 1] + u * (T[i1, 1] - T[i0, 1])
        dfx, dfy = (T[i1, 0] - T[i0, 0]) / s1, (T[i1, 1] - T[i0, 1]) / s1
    else:
        u = min(1.0, max(0.0, (s - s1) / (1.0 - s1)))
        fx = T[i1, 0] + u * (T[i2, 0] - T[i1, 0])
        fy = T[i1, 1] + u * (T[i2, 1] - T[i1, 1])
        dfx, dfy = (T[i2, 0] - T[i1, 0]) / (1.0 - s1), (T[i2, 1] - T[i1, 1]) / (1.0 - s1)
    h = T[i0, 2] + s * (T[i2, 2] - T[i0, 2])
    dh = T[i2, 2] - T[i0, 2]
    gx, gy = fx - ex, fy - ey
    L2 = gx * gx + gy * gy
    w = 0.0
    if L2 > 0.0:
        w = min(1.0, max(0.0, -(ex * gx + ey * gy) / L2))
    qx, qy = ex + w * gx, ey + w * gy
    r = math.sqrt(qx * qx + qy * qy)
    sd, gr, gh = signed_distance_gradient(core, r, h)
    C = max(math.sqrt(dex * dex + dey * dey), math.sqrt(dfx * dfx + dfy * dfy))
    scale = math.sqrt(ex * ex + ey * ey) + math.sqrt(fx * fx + fy * fy)
    if r <= 1e-12 * scale or r == 0.0:
        mlo, mhi = -C, C
    else:
        ux, uy = qx / r, qy / r
        if math.sqrt(L2) <= 1e-7 * scale:
            a1 = ux * dex + uy * dey
            a2 = ux * dfx + uy * dfy
            widen = C * (2.0 * math.sqrt(L2) / r + 1e-12)
            mlo, mhi = min(a1, a2) - widen, max(a1, a2) + widen
        else:
            # the slices of a plane are parallel: u is normal to D and D' where w is inside
            # (0, 1), so mu does not depend on w's rounding; the margin covers mu's own
            mu = ux * (dex + w * (dfx - dex)) + uy * (dey + w * (dfy - dey))
            mlo, mhi = mu - 1e-12 * C, mu + 1e-12 * C
    gr = max(gr, 0.0)
    return SliceValue(sd, gr * mlo + gh * dh, gr * mhi + gh * dh, (qx, qy, h))


@nb.njit(cache=True)
def _bracket_low(a, fa, ga, b, fb, gb):
    """Lower bound of a convex function on [a, b] from its values and end slopes (ga: a slope
    valid to the right of a, gb to the left of b): the tangents' meeting point."""
    if ga >= 0.0:
        return fa, a
    if gb <= 0.0:
        return fb, b
    hc = (fb - fa + ga * a - gb * b) / (ga - gb)
    hc = min(b, max(a, hc))
    return max(fa + ga * (hc - a), fb + gb * (hc - b)), hc


@nb.njit(cache=True)
def _fresh(br, k):
    """Bracket k starts its bookkeeping anew."""
    br[k, _STALLS] = 0.0
    br[k, _SECANT] = 0.0
    br[k, _LAST] = 0.0
    br[k, _SCALE_A] = 1.0
    br[k, _SCALE_B] = 1.0


@nb.njit(cache=True)
def _illinois(br, k, side, poor):
    """Bookkeeping after end `side` (-1 a, +1 b) of bracket k was replaced; `poor`: the bracket
    did not halve."""
    br[k, _STALLS] = br[k, _STALLS] + 1.0 if poor else 0.0
    if side > 0.0:
        br[k, _SCALE_B] = 1.0
        if br[k, _LAST] > 0.0:
            br[k, _SCALE_A] *= 0.5
    else:
        br[k, _SCALE_A] = 1.0
        if br[k, _LAST] < 0.0:
            br[k, _SCALE_B] *= 0.5
    br[k, _LAST] = side


@nb.njit(cache=True)
def _set_end(br, k, column, level, f):
    """End a (column _A) or b (_B) of bracket k at `level`: phi's value and the slope on the
    bracket's side."""
    br[k, column] = level
    br[k, column + 1] = f.value
    br[k, column + 2] = f.slope_lo if column == _A else f.slope_hi


@nb.njit(cache=True)
def exact_value(T, core, best, br):
    """The signed value of triangle T (tool frame) against the piece, rho - min over T of the
    signed distance to K (mm), if it beats `best`, else -inf; and T's point of that value.
    `br (BRACKETS, BRACKET_COLUMNS)` scratch.

    phi (module docstring) is bracketed by tangent lines (each evaluation gives an interval
    holding phi's subgradients; a bracket whose probe's interval holds 0 is split in two),
    probing in turn where the end tangents meet (exact at a kink between two straight pieces)
    and where the secant of phi' vanishes (exact for a parabola; the Illinois rule keeps it from
    converging from one side only), or halving after four probes that did not halve a bracket,
    until the best value found is within SLICE_EPS of the lowest bracket bound, or that bound
    shows T cannot beat `best`."""
    i0, i1, i2 = 0, 1, 2
    if T[i1, 2] < T[i0, 2]:
        i0, i1 = i1, i0
    if T[i2, 2] < T[i1, 2]:
        i1, i2 = i2, i1
    if T[i1, 2] < T[i0, 2]:
        i0, i1 = i1, i0
    order = (i0, i1, i2)
    zr = T[i2, 2] - T[i0, 2]
    s1 = (T[i1, 2] - T[i0, 2]) / zr if zr > 0.0 else 0.5
    thresh = core.rho - best       # phi must go below this
    f = _slice_at(T, order, s1, 0.0, core)
    fbest = f.value
    point = f.point
    _set_end(br, 0, _A, 0.0, f)
    f = _slice_at(T, order, s1, 1.0, core)
    if f.value < fbest:
        fbest = f.value
        point = f.point
    _set_end(br, 0, _B, 1.0, f)
    _fresh(br, 0)
    nbr = 1
    conservative = False
    lmin = np.inf
    for _ in range(400):
        kmin = -1
        lmin = np.inf
        hmin = 0.0
        for k in range(nbr):
            lb, hc = _bracket_low(br[k, _A], br[k, _FA], br[k, _GA], br[k, _B], br[k, _FB],
                                  br[k, _GB])
            if lb < lmin:
                lmin, kmin, hmin = lb, k, hc
        if kmin < 0 or lmin >= thresh:
            if kmin >= 0 or fbest >= thresh:
                return -np.inf, point
            break
        if fbest - lmin <= SLICE_EPS:
            break
        a, ga = br[kmin, _A], br[kmin, _GA]
        b, gb = br[kmin, _B], br[kmin, _GB]
        if b - a <= 4e-16 or ga >= 0.0 or gb <= 0.0:
            # exhausted (its ends are evaluated): drop it
            for c in range(BRACKET_COLUMNS):
                br[kmin, c] = br[nbr - 1, c]
            nbr -= 1
            continue
        # in turn: the tangents' meeting (exact at a kink) and the secant on phi' (exact for a
        # parabola; Illinois: the slope of an end kept twice is halved); halving after four
        # probes that did not halve the bracket
        if br[kmin, _SECANT] > 0.0:
            sa, sb = ga * br[kmin, _SCALE_A], gb * br[kmin, _SCALE_B]
            hc = a - sa * (b - a) / (sb - sa)
        else:
            hc = hmin
        br[kmin, _SECANT] = 1.0 - br[kmin, _SECANT]
        if br[kmin, _STALLS] >= 4.0 or not (hc > a and hc < b):
            hc = 0.5 * (a + b)
            br[kmin, _STALLS] = 0.0
        f = _slice_at(T, order, s1, hc, core)
        if f.value < fbest:
            fbest = f.value
            point = f.point
        width = b - a
        if f.slope_lo > 0.0:                     # the minimum is left of hc
            _set_end(br, kmin, _B, hc, f)
            _illinois(br, kmin, 1.0, hc - a > 0.5 * width)
        elif f.slope_hi < 0.0:                   # right of hc
            _set_end(br, kmin, _A, hc, f)
            _illinois(br, kmin, -1.0, b - hc > 0.5 * width)
        elif nbr < BRACKETS:                     # either side: split
            for c in range(BRACKET_COLUMNS):
                br[nbr, c] = br[kmin, c]
            _set_end(br, kmin, _B, hc, f)
            _set_end(br, nbr, _A, hc, f)
            _fresh(br, kmin)
            _fresh(br, nbr)
            nbr += 1
        else:
            conservative = True
            break
    if conservative:
        fbest = min(fbest, lmin)     # a lower bound of the minimum: never shallow
    val = core.rho - fbest
    if val > best:
        return val, point
    return -np.inf, point
