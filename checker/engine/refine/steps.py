"""Local refinement in (u, v), compiled whole: every start (a CC row and a point on one
surface) takes up to `iterations` quadratic-model steps; the rows run in parallel, each row's
starts together (`_refine_row`), so that no Python runs per step. Each step evaluates a 3x3
stencil, fits the quadratic (central differences), takes the bounded Newton step when the model
is convex (the best stencil point otherwise) with backtracking to the first fraction that
improves, and shrinks the stencil as it converges. Steps stay inside the surface domain; points
outside a trim count as inf. The answer is the best point evaluated. Starts far above their
row's best are dropped, and starts that meet (same row, surface and _SAME cell) go on as one.

Near the CC point the size can have narrow curved valleys: a point a few microns off the
valley floor has a much larger size, while the floor falls slowly over a millimetre. The
stencil cannot follow them. Where it stalls, the start walks instead (`_walk`): trust-region
Newton steps with derivatives from differences a _DELTA wide, each followed by Newton steps
across the valley (along the Hessian's steep direction), so that steps of a tenth of a
millimetre stay on the floor.

Surface evaluation is the expensive part, so each step evaluates the surface once per start:
exactly, with second derivatives, at the point the step picks (`_exact`). The stencil, the
Newton step, its backtracking and the walk run on the second-order Taylor model of the surface
about the start's best point (error O(h^3) for a step of length h, so the model becomes exact as
the steps converge); only exact values are ever reported. The model's value (`_model_value`) is
inlined at its seven sites (a call passes the whole model, about a hundred words, for every
value: a call at the walk's four sites alone ran the ball and bull-nose engine slower), and so
are the small kernels, by LLVM (`forceinline=True`: the compiled function marked always- inline
where it is linked in), not by numba (`inline="always"` copies and types the callee's IR again
at every site, nested sites included, which cost about a third of the compile;
`benchmarks/bench_compile.py`). The kernels that allocate nothing are compiled without numba's
reference counting (`_nrt=False`): with it, every array a call passes or unpacks from a tuple is
counted up and down atomically, a large part of a call, more on two threads (both count the same
arrays). Counts and indices passed to kernels are int64 values, not Python int constants
(`evaluate.ZERO`, `np.int64(index)`): numba compiles a kernel again for each literal value it is
passed and for a parallel loop's uint64 index. The evaluation's order and the exact value of one
point stay constants (their loops then have fixed lengths: the engine ran slower without, the
flat end-mill most). (docs/MATH.md §6)"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.engine.grid.rotations import rotated, row_height
from checker.engine.refine.objective import FLOOR_STEPS, Objective, exact_size, point_batch
from checker.engine.sizes import RowFrame, SizeArgs, point_size
from checker.geometry.evaluate import ZERO, eval_range
from checker.geometry.newton_uv import newton_step
from checker.geometry.trims import PackedTrims, kept
from checker.part import Part

_ON_FLOOR = 1e-6  # mm: points this close above the bottom plane lie on its contour
_FRACTIONS = np.array([1.0, 0.5, 0.25, 0.125])
_REACH = 4.0  # longest Newton step, stencil half-widths
_PRUNE_AFTER = 2  # iterations before starts far above their row's best are dropped
_PRUNE_REL, _PRUNE_ABS = 0.01, 0.02  # 'far above': more than 1 % + 0.02 mm
_CONVERGED = 1e-5  # a start stops when its stencil is this fraction of the initial one
_OFFS = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=np.float64)
# the walk's difference points, in _DELTA steps along u and v: +u, -u, +v, -v, +u+v
_DIFFS = np.array([(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1)], dtype=np.float64)
_CENTRE = 4  # index of the stencil centre in _OFFS
_SAME = 1e-3  # mm: starts whose best points are this close have met
_TASKS = 64  # parallel tasks the rows are interleaved over
_DELTA = 1e-4  # mm: difference step of the walk's derivatives
_GROW, _SHRINK = 2.0, 0.25  # trust radius and reach factors after a success and a failure
_RADIUS_CAP, _CAP_MM = 64.0, 1.0  # longest walk and trust radius: initial radii, at least mm
_WALK_STEPS = 4  # trust-region steps of a walk
_ACROSS = 2  # Newton steps across the valley after each of them
_STILL = 1e-7  # mm: a walk whose model predicts less decrease than this has arrived
_SECULAR_STEPS = 60  # at most this many steps to the trust region's boundary lambda
_MOVED = 1e-3  # mm: a start that arrived walks again once it has moved this far
# rows of a start's Taylor terms (`d[s]` of the model M below; the point and first derivatives
# also of the model's value at a point, `e`): the point, S_u, S_v, S_uu, S_uv, S_vv
_POINT, _DU, _DV, _DUU, _DUV, _DVV = range(6)
# columns of the per-start walk radii (mm): the trust radius (negative: the walk has arrived),
# the reach (longest walk) and the cap of both
_R_TRUST, _R_REACH, _R_CAP = range(3)
# entries of a walk's domain box: offsets (mm) of the domain's bounds from the walk's centre
_U_LO, _U_HI, _V_LO, _V_HI = range(4)


class _Model(NamedTuple):
    """The model the compiled steps evaluate the starts with (`M` in the kernels): the starts'
    Taylor terms `d (S, 6, 3)` (rows _POINT.._DVV) about their (u, v) `uv0 (S, 2)`, the rows'
    rotations `Q (N, 3, 3)` part -> tool frame and bottom planes `floor (N,)` (tool-frame
    height; empty: none), the surfaces' domains `dom (surfaces, 2, 2)`, the rows' `sz`
    (sizes.size_args) and the packed trims `T`; always unpacked whole."""

    d: np.ndarray
    uv0: np.ndarray
    Q: np.ndarray
    floor: np.ndarray
    dom: np.ndarray
    sz: SizeArgs
    T: PackedTrims


class _ModelValue(NamedTuple):
    """The model's size at (u, v), and (u, v) themselves (moved onto the bottom plane where
    that applies)."""

    size: float
    u: float
    v: float


@dataclass
class Refined:
    """Per start: `size (S,)` mm, `uv (S, 2)`, `point (S, 3)` part frame, `evaluations (S,)`
    (imaginary sizes computed, on the surface or on its Taylor model)."""

    size: np.ndarray
    uv: np.ndarray
    point: np.ndarray
    evaluations: np.ndarray


@nb.njit(cache=True, forceinline=True)
def _taylor_at(d, uv0, s, u, v, out):
    """Point and first derivatives (rows _POINT, _DU, _DV of `out`, part frame) of start s's
    Taylor model at (u, v)."""
    a = u - uv0[s, 0]
    b = v - uv0[s, 1]
    for m in range(3):
        su = d[s, _DU, m] + a * d[s, _DUU, m] + b * d[s, _DUV, m]
        sv = d[s, _DV, m] + a * d[s, _DUV, m] + b * d[s, _DVV, m]
        out[_POINT, m] = d[s, _POINT, m] + 0.5 * (a * (su + d[s, _DU, m]) + b * (sv + d[s, _DV, m]))
        out[_DU, m] = su
        out[_DV, m] = sv


@nb.njit(cache=True, forceinline=True)
def _onto_level(excess, hu, hv, u, v, lo_u, hi_u, lo_v, hi_v):
    """The step (du, dv) that brings a height `excess` mm above a level (negative: below) to it,
    the height's derivatives being (hu, hv): the projected Newton step on excess^2 / 2
    (newton_uv.py), so that a point slides along a domain edge instead of stopping at it."""
    return newton_step(excess * hu, excess * hv, hu * hu, hu * hv, hv * hv, u, v, lo_u, hi_u,
                       lo_v, hi_v, False, False)


@nb.njit(cache=True, _nrt=False, forceinline=True)
def _model_value(M, s, r, sd, u, v, snap, e):
    """The `_ModelValue` of start s's Taylor model (M, above) at (u, v) for CC row r,
    surface sd (rules of `sizes.point_size`, tool frame through Q, inf outside the trim). With a
    floor a point below it (with `snap`: any point) first moves onto it by Newton steps on the
    model's height, clipped to the domain; (u, v) come back moved."""
    d, uv0, Q, floor, dom, sz, T = M
    lo_u, hi_u, lo_v, hi_v = dom[sd, 0, 0], dom[sd, 0, 1], dom[sd, 1, 0], dom[sd, 1, 1]
    _taylor_at(d, uv0, s, u, v, e)
    for _ in range(FLOOR_STEPS if floor.shape[0] else 0):
        z = row_height(Q, r, e, _POINT)
        if z >= floor[r] and not (snap and z - floor[r] > _ON_FLOOR):
            break
        du, dv = _onto_level(z - floor[r], row_height(Q, r, e, _DU), row_height(Q, r, e, _DV), u,
                             v, lo_u, hi_u, lo_v, hi_v)
        if du == 0.0 and dv == 0.0:
            break
        u = min(max(u + du, lo_u), hi_u)
        v = min(max(v + dv, lo_v), hi_v)
        _taylor_at(d, uv0, s, u, v, e)
    x, y, z = rotated(Q, r, e, _POINT)
    f = point_size(sz, r, x, y, z) if kept(T, sd, u, v) else np.inf
    return _ModelValue(f, u, v)


@nb.njit(cache=True, forceinline=True)
def _near_floor(Q, r, d, s, best_p, floor, hu, hv):
    """Whether start s's best point lies on row r's bottom plane or within the height range of
    its stencil (half-widths hu, hv) above it: the contour steps apply."""
    span = abs(row_height(Q, r, d[s], _DU)) * hu + abs(row_height(Q, r, d[s], _DV)) * hv
    return row_height(Q, r, best_p, s) - floor[r] <= max(_ON_FLOOR, span)


@nb.njit(cache=True, forceinline=True)
def _newton_target(F, cu, cv, hu, hv):
    """Newton point (u, v) of the quadratic through the 3x3 stencil values F (9,) about
    (cu, cv) (central differences, half-widths hu, hv), at most _REACH half-widths per
    coordinate; ok False where the model is not finite or not convex; clipped True where the
    step was cut to that length."""
    for j in range(9):
        if not np.isfinite(F[j]):
            return False, False, cu, cv
    gu = (F[7] - F[1]) / (2 * hu)
    gv = (F[5] - F[3]) / (2 * hv)
    huu = (F[7] - 2 * F[4] + F[1]) / hu**2
    hvv = (F[5] - 2 * F[4] + F[3]) / hv**2
    huv = (F[8] - F[6] - F[2] + F[0]) / (4 * hu * hv)
    det = huu * hvv - huv * huv
    if not (huu > 0 and det > 0):
        return False, False, cu, cv
    du = -(hvv * gu - huv * gv) / det
    dv = -(huu * gv - huv * gu) / det
    du = du if np.isfinite(du) else 0.0
    dv = dv if np.isfinite(dv) else 0.0
    scale = 1.0
    if abs(du) > _REACH * hu:
        scale = _REACH * hu / abs(du)
    if abs(dv) > _REACH * hv:
        scale = min(scale, _REACH * hv / abs(dv))
    return True, scale < 1.0, cu + du * scale, cv + dv * scale


@nb.njit(cache=True, forceinline=True)
def _speeds(d, s):
    """|S_u|, |S_v| (mm per parameter unit) at start s's model centre."""
    return (np.sqrt(d[s, _DU, 0] ** 2 + d[s, _DU, 1] ** 2 + d[s, _DU, 2] ** 2),
            np.sqrt(d[s, _DV, 0] ** 2 + d[s, _DV, 1] ** 2 + d[s, _DV, 2] ** 2))


@nb.njit(cache=True, _nrt=False, forceinline=True)
def _derivatives(M, s, r, sd, u0, v0, f0, su, sv, e, F):
    """(ok, gradient (gu, gv), Hessian (huu, huv, hvv)) of start s's model size at (u0, v0)
    (value f0 there), per mm along u and v (su, sv: mm per parameter unit): central differences
    of width _DELTA, the cross term forward (the values at _DIFFS into F); ok False where a value
    is not finite."""
    du, dv = _DELTA / su, _DELTA / sv
    for j in range(_DIFFS.shape[0]):
        F[j] = _model_value(M, s, r, sd, u0 + _DIFFS[j, 0] * du, v0 + _DIFFS[j, 1] * dv, False,
                            e).size
    fup, fum, fvp, fvm, fpp = F[0], F[1], F[2], F[3], F[4]
    if not np.isfinite(fup + fum + fvp + fvm + fpp + f0):
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    return (True, (fup - fum) / (2 * _DELTA), (fvp - fvm) / (2 * _DELTA),
            (fup - 2 * f0 + fum) / _DELTA**2, (fpp - fup - fvp + f0) / _DELTA**2,
            (fvp - 2 * f0 + fvm) / _DELTA**2)


@nb.njit(cache=True, forceinline=True)
def _eigen(huu, huv, hvv):
    """Eigenvalues l1 <= l2 of the symmetric 2x2 matrix [[huu, huv], [huv, hvv]] and the unit
    eigenvector (x1, y1) of l1 (the one of l2 is (-y1, x1))."""
    half, mid = 0.5 * (huu - hvv), 0.5 * (huu + hvv)
    root = np.sqrt(half * half + huv * huv)
    l1, l2 = mid - root, mid + root
    x1, y1 = huv, l1 - huu  # either form of the eigenvector, the longer one
    if (l1 - hvv) ** 2 + huv * huv > x1 * x1 + y1 * y1:
        x1, y1 = l1 - hvv, huv
    nrm = np.sqrt(x1 * x1 + y1 * y1)
    x1, y1 = (x1 / nrm, y1 / nrm) if nrm > 1e-300 else (1.0, 0.0)
    return l1, l2, x1, y1


@nb.njit(cache=True, forceinline=True)
def _boundary_lambda(g1, g2, l1, l2, radius, lo, hi):
    """The lambda in [lo, hi] at which the step of H + lambda I, (-g1 / (l1 + lambda),
    -g2 / (l2 + lambda)) in H's eigenbasis (eigenvalues l1 <= l2, gradient (g1, g2)), is
    `radius` long, the step being longer at lo (>= -l1) and no longer at hi: Newton's method on
    phi = 1 / radius - 1 / |p|, convex and decreasing in lambda (Moré and Sorensen), whose
    iterates close in from the left of the root, kept inside the bracket by bisection; to
    rounding in a few iterations where bisection took 60."""
    tol = 1e-15 * hi
    lam = hi
    for _ in range(_SECULAR_STEPS):
        a1, a2 = l1 + lam, l2 + lam
        if a1 > 0.0:  # else at the pole: bisect
            p1, p2 = g1 / a1, g2 / a2
            n2 = p1 * p1 + p2 * p2
            if n2 > radius * radius:
                lo = lam
            else:
                hi = lam
            q2 = p1 * p1 / a1 + p2 * p2 / a2  # -d|p|^2 / dlambda / 2
            if not (n2 > 0.0 and q2 > 0.0):
                return hi
            new = lam + n2 / q2 * (np.sqrt(n2) - radius) / radius
            if abs(new - lam) <= tol:  # converged to rounding
                return min(max(new, lo), hi)
            if lo < new < hi:
                lam = new
                continue
        lam = 0.5 * (lo + hi)
        if hi - lo <= tol:
            return hi
    return hi


@nb.njit(cache=True, forceinline=True)
def _trust_region(gu, gv, huu, huv, hvv, radius):
    """The step (pu, pv) that minimises the quadratic g.p + p.H.p / 2 over |p| <= radius (2D,
    through H's eigenvectors: the Newton step where H is positive definite and the step is
    short enough, else H + lambda I on the boundary, `_boundary_lambda`)."""
    l1, l2, x1, y1 = _eigen(huu, huv, hvv)
    x2, y2 = -y1, x1
    g1, g2 = gu * x1 + gv * y1, gu * x2 + gv * y2
    lam = 0.0
    if not (l1 > 0.0 and (g1 / l1) ** 2 + (g2 / l2) ** 2 <= radius * radius):
        lo = max(0.0, -l1)
        lam = _boundary_lambda(g1, g2, l1, l2, radius, lo,
                               lo + np.sqrt(gu * gu + gv * gv) / radius + 1e-300)
    a1, a2 = l1 + lam, l2 + lam
    c1, c2 = -g1 / a1 if a1 > 0.0 else 0.0, -g2 / a2 if a2 > 0.0 else 0.0
    if l1 < 0.0:  # the hard case: the rest of the radius along the negative curvature
        c1 += (1.0 if c1 >= 0.0 else -1.0) * np.sqrt(max(radius * radius - c1 * c1 - c2 * c2, 0.0))
    length = np.sqrt(c1 * c1 + c2 * c2)
    if length > radius:  # lambda next to -l1 leaves l1 + lambda to rounding: back to the radius
        c1, c2 = c1 * radius / length, c2 * radius / length
    return c1 * x1 + c2 * x2, c1 * y1 + c2 * y2


@nb.njit(cache=True, forceinline=True)
def _line_step(g, hh, radius):
    """The step along one coordinate that minimises g p + hh p^2 / 2 over |p| <= radius."""
    if hh > 0.0:
        return min(max(-g / hh, -radius), radius)
    return -radius if g > 0.0 else radius


@nb.njit(cache=True, forceinline=True)
def _fraction_inside(p, lo, hi):
    """The largest fraction (<= 1) of a step p that stays within [lo, hi] (lo <= 0 <= hi; a
    centre up to _DELTA outside its box takes no step across the bound, and a zero step is
    whole)."""
    if p == 0.0:
        return 1.0
    if p < lo:
        return max(lo, 0.0) / p
    if p > hi:
        return max(hi, 0.0) / p
    return 1.0


@nb.njit(cache=True, forceinline=True)
def _boxed_step(gu, gv, huu, huv, hvv, radius, box):
    """`_trust_region`'s step kept inside the domain `box` = (u lo, u hi, v lo, v hi), offsets
    from the centre in mm: a coordinate whose bound the centre lies on and the step would
    cross is held there and the other takes its own line step; a step that crosses a bound
    from inside stops at it. Returns (pu, pv, the decrease the quadratic predicts)."""
    pu, pv = _trust_region(gu, gv, huu, huv, hvv, radius)
    if (pu < box[_U_LO] and box[_U_LO] > -_DELTA) or (pu > box[_U_HI] and box[_U_HI] < _DELTA):
        pu, pv = 0.0, _line_step(gv, hvv, radius)
    elif (pv < box[_V_LO] and box[_V_LO] > -_DELTA) or (pv > box[_V_HI] and box[_V_HI] < _DELTA):
        pu, pv = _line_step(gu, huu, radius), 0.0
    t = min(_fraction_inside(pu, box[_U_LO], box[_U_HI]),
            _fraction_inside(pv, box[_V_LO], box[_V_HI]))
    pu, pv = t * pu, t * pv
    pred = -(gu * pu + gv * pv + 0.5 * (huu * pu * pu + 2.0 * huv * pu * pv + hvv * pv * pv))
    return pu, pv, pred


@nb.njit(cache=True, _nrt=False)
def _walk(M, s, r, sd, f0, radius, box, e, F):
    """Trust-region Newton steps on start s's model from its centre (value f0; derivatives
    from `_derivatives`), each followed by up to _ACROSS Newton steps across the valley (along
    the Hessian's steep direction), which keeps long steps on the floor of narrow curved
    valleys. Up to _WALK_STEPS steps while they improve, in all at most radius[s, _R_REACH] mm;
    the trust radius radius[s, _R_TRUST] mm grows after a full-length step that improved,
    shrinks after one that did not, and turns negative where the model predicts no more
    decrease (in place). A step that reaches below the bottom plane of a flat-bottomed cutter
    ends the walk (the contour steps go on from there). `F` (>= 5): scratch for model values.
    Returns (value, u, v, the distance walked in mm, model values computed)."""
    d, uv0, _, _, dom, _, _ = M
    lo_u, hi_u, lo_v, hi_v = dom[sd, 0, 0], dom[sd, 0, 1], dom[sd, 1, 0], dom[sd, 1, 1]
    su, sv = _speeds(d, s)
    su, sv = max(su, 1e-300), max(sv, 1e-300)
    u, v = uv0[s, 0], uv0[s, 1]
    f, walked, probes = f0, 0.0, 0  # f: the value at (u, v), where the walk stands
    for _ in range(_WALK_STEPS):
        ok, gu, gv, huu, huv, hvv = _derivatives(M, s, r, sd, u, v, f, su, sv, e, F)
        probes += 5
        step = min(radius[s, _R_TRUST], radius[s, _R_REACH] - walked)
        if not ok or step < _DELTA:
            break
        box[_U_LO], box[_U_HI] = (lo_u - u) * su, (hi_u - u) * su
        box[_V_LO], box[_V_HI] = (lo_v - v) * sv, (hi_v - v) * sv
        pu, pv, pred = _boxed_step(gu, gv, huu, huv, hvv, step, box)
        if not pred > _STILL:  # the model's minimum: walks end here until the start moves
            radius[s, _R_TRUST] = -radius[s, _R_TRUST]
            break
        x = min(max(u + pu / su, lo_u), hi_u)
        y = min(max(v + pv / sv, lo_v), hi_v)
        ft, xs, ys = _model_value(M, s, r, sd, x, y, False, e)
        probes += 1
        if xs != x or ys != y:  # moved onto the bottom plane: the contour steps go on from here
            if ft < f:
                u, v, f = xs, ys, ft
            break
        _, _, x1, y1 = _eigen(huu, huv, hvv)
        tu, tv = -y1, x1  # across the valley: the eigenvector of the larger eigenvalue
        for _ in range(_ACROSS):  # Newton steps across the valley, back onto its floor
            for j in range(2):  # the values a _DELTA either side
                side = 1.0 - 2.0 * j
                F[j] = _model_value(M, s, r, sd, x + side * (_DELTA * tu / su),
                                    y + side * (_DELTA * tv / sv), False, e).size
            fp, fm = F[0], F[1]
            probes += 3
            curv = (fp - 2.0 * ft + fm) / _DELTA**2
            if not (curv > 0.0 and np.isfinite(fp + fm)):
                break
            c = _line_step((fp - fm) / (2.0 * _DELTA), curv, step)
            xc = min(max(x + c * tu / su, lo_u), hi_u)
            yc = min(max(y + c * tv / sv, lo_v), hi_v)
            fc, xc, yc = _model_value(M, s, r, sd, xc, yc, False, e)
            if not fc < ft:
                break
            ft, x, y = fc, xc, yc
        length = np.sqrt(pu * pu + pv * pv)
        if not ft < f:
            radius[s, _R_TRUST] = max(_SHRINK * length, _DELTA)
            break
        if length > 0.99 * radius[s, _R_TRUST]:  # the quadratic's along-valley curvature is
            # noise: success alone grows the trust radius
            radius[s, _R_TRUST] = min(_GROW * radius[s, _R_TRUST], radius[s, _R_CAP])
        walked += np.sqrt(((x - u) * su) ** 2 + ((y - v) * sv) ** 2)
        u, v, f = x, y, ft
    return f, u, v, walked, probes


class _Step(NamedTuple):
    """What one model step of a start found: the best (u, v) it reached, whether a Newton step
    or the walk won (`newton`), a contour step won (`along`), the stencil centre was best
    (`centre`), the walk won (`walked`), and the model values computed (`probes`)."""

    u: float
    v: float
    newton: bool
    along: bool
    centre: bool
    walked: bool
    probes: int


class _StepScratch(NamedTuple):
    """Work arrays of `_step` (one set per thread): the model's point and derivatives `e`,
    the stencil's values `F` and (u, v) `U`, the contour probes' `vals` and `uvs`, the walk's
    domain `box`."""

    e: np.ndarray
    F: np.ndarray
    U: np.ndarray
    vals: np.ndarray
    uvs: np.ndarray
    box: np.ndarray


@nb.njit(cache=True, forceinline=True)
def _step_scratch() -> _StepScratch:
    """A fresh `_StepScratch`."""
    m = 2 + _FRACTIONS.shape[0]
    return _StepScratch(np.empty((3, 3)), np.empty(9), np.empty((9, 2)), np.empty(m),
                        np.empty((m, 2)), np.empty(4))


@nb.njit(cache=True, _nrt=False)
def _step(M, s, r, sd, best_uv, best_f, best_p, h, radius, walked, sc):
    """One model step of start s (row r, surface sd) on its Taylor model M: the 3x3 stencil of
    half-widths h[s] about its best (u, v) (moved inside the domain), the Newton step of the
    stencil's quadratic (the best stencil point where that is not finite or not convex) with
    backtracking to the first of _FRACTIONS that improves, and for flat-bottomed cutters, where
    the start's best point lies on the bottom plane, the steps along its contour, elsewhere,
    where the stencil stalled, a `_walk` (radii `radius[s]`, columns `_R_*`; the distance
    walked into `walked[s]`, mm). Returns the `_Step`."""
    d, _, Q, floor, dom, _, _ = M
    e, F, U, vals, uvs, box = sc
    hu, hv = h[s, 0], h[s, 1]
    lo_u, hi_u, lo_v, hi_v = dom[sd, 0, 0], dom[sd, 0, 1], dom[sd, 1, 0], dom[sd, 1, 1]
    cu = min(max(best_uv[s, 0], lo_u + hu), hi_u - hu)
    cv = min(max(best_uv[s, 1], lo_v + hv), hi_v - hv)
    for j in range(9):  # the stencil, row-major over du in -1, 0, 1 then dv
        F[j], U[j, 0], U[j, 1] = _model_value(M, s, r, sd, cu + _OFFS[j, 0] * hu,
                                              cv + _OFFS[j, 1] * hv, False, e)
    jbest = _CENTRE  # the centre unless a point is lower, else the first lowest
    for j in range(9):
        if F[j] < F[jbest]:
            jbest = j
    ok, clipped, tu, tv = _newton_target(F, cu, cv, hu, hv)
    if not ok:
        tu, tv = U[jbest, 0], U[jbest, 1]
    fc, nu, nv = F[jbest], U[jbest, 0], U[jbest, 1]
    newton = False
    probes = 9
    for t in range(_FRACTIONS.shape[0]):  # backtracking along the step
        x = min(max(cu + _FRACTIONS[t] * (tu - cu), lo_u), hi_u)
        y = min(max(cv + _FRACTIONS[t] * (tv - cv), lo_v), hi_v)
        ft, x, y = _model_value(M, s, r, sd, x, y, False, e)
        probes += 1
        if ft < fc:
            fc, nu, nv, newton = ft, x, y, True
            break
    along, trust = False, False
    if floor.shape[0] and _near_floor(Q, r, d, s, best_p, floor, hu, hv):
        n = _contour_probes(M, s, r, sd, best_f[s], fc, hu, hv, vals, uvs, e)
        probes += n
        for j in range(n):
            if vals[j] < fc:
                fc, nu, nv, along = vals[j], uvs[j, 0], uvs[j, 1], True
    elif (clipped or not newton) and radius[s, _R_TRUST] > 0.0:  # the stencil stuck: walk
        ft, x, y, walked[s], n = _walk(M, s, r, sd, best_f[s], radius, box, e, F)
        probes += n
        if ft < fc:
            fc, nu, nv, trust = ft, x, y, True
    return _Step(nu, nv, newton or trust, along, jbest == _CENTRE, trust, probes)


@nb.njit(cache=True, _nrt=False)
def _contour_probes(M, s, r, sd, f0, fc, hu, hv, vals, uvs, e):
    """Model values `vals` and (u, v) `uvs` along the bottom-plane contour through start s's
    model centre (value f0), every point snapped onto the plane: at -tau and +tau mm (tau from
    the stencil half-widths), then at the fractions of the parabola's vertex, until one is
    below fc and both of the first. Returns their count."""
    d, uv0, Q, _, dom, _, _ = M
    lo_u, hi_u, lo_v, hi_v = dom[sd, 0, 0], dom[sd, 0, 1], dom[sd, 1, 0], dom[sd, 1, 1]
    gu = row_height(Q, r, d[s], _DU)  # the height's derivatives in u and v
    gv = row_height(Q, r, d[s], _DV)
    mm = 0.0
    for m in range(3):
        mm += (-gv * d[s, _DU, m] + gu * d[s, _DV, m]) ** 2  # the contour tangent, mm per unit
    mm = max(np.sqrt(mm), 1e-300)
    tu, tv = -gv / mm, gu / mm  # (u, v) per mm along the contour
    su, sv = _speeds(d, s)
    tau = 0.5 * (hu * su + hv * sv)
    vertex = 0.0
    for n in range(2 + _FRACTIONS.shape[0]):  # one site of the inlined model value
        if n < 2:
            t = tau if n else -tau
        else:
            if n == 2:
                vertex = _vertex(f0, vals[0], vals[1], tau)
            t = vertex * _FRACTIONS[n - 2]
        x = min(max(uv0[s, 0] + t * tu, lo_u), hi_u)
        y = min(max(uv0[s, 1] + t * tv, lo_v), hi_v)
        vals[n], uvs[n, 0], uvs[n, 1] = _model_value(M, s, r, sd, x, y, True, e)
        if n >= 2 and vals[n] < min(fc, vals[0], vals[1]):
            return n + 1
    return 2 + _FRACTIONS.shape[0]


@nb.njit(cache=True, forceinline=True)
def _vertex(f0, fm, fp, tau):
    """The offset (mm) of the vertex of the parabola through the values fm, f0, fp at -tau, 0
    and tau, at most _REACH tau either way (towards the lower side where it opens downwards)."""
    curv = fm - 2.0 * f0 + fp
    if curv > 0:
        vertex = tau * (fm - fp) / (2.0 * curv)
    elif fm != fp:
        vertex = (1.0 if fm > fp else -1.0) * _REACH * tau
    else:
        vertex = 0.0
    return min(max(vertex if np.isfinite(vertex) else 0.0, -_REACH * tau), _REACH * tau)


@nb.njit(cache=True, _nrt=False)
def _exact(G, M, r, k, bt):
    """Exact sizes bt.size[:k] of row r at the surface points (bt.sid, bt.u, bt.v)[:k] (their
    order-2 evaluation into bt.ev; packed surfaces G), points below the bottom plane of a
    flat-bottomed cutter moved onto it first (bt.u, bt.v updated; objective.py)."""
    _, _, Q, floor, dom, sz, T = M
    eval_range(G, bt.sid, bt.u, bt.v, 2, bt.ev, bt.normals, ZERO, k, bt.sc)
    for j in range(k):
        bt.size[j] = exact_size(G, Q, floor, dom, sz, T, r, bt.sid, bt.u, bt.v, bt.ev,
                                bt.normals, bt.sc, j, 2)


@nb.njit(cache=True, forceinline=True)
def _centre(d, uv0, s, j, bt):
    """Start s's Taylor model re-centred on the batch's point j."""
    uv0[s, 0], uv0[s, 1] = bt.u[j], bt.v[j]
    for m in range(6):
        for c in range(3):
            d[s, m, c] = bt.ev[j, m, c]


@nb.njit(cache=True, forceinline=True)
def _pruned(best_f, best_p, sid, idx, active, cells):
    """Of a row's starts `idx` (ascending), those far above the row's best no longer active
    (more than _PRUNE_REL + _PRUNE_ABS), and of the active ones whose best points (part frame)
    share a cell of _SAME mm on one surface only the lowest (the first of equals): they have
    met, and go on as one (in place; `cells (k, 3)`: scratch for the cells)."""
    k = idx.shape[0]
    row_best = np.inf
    for i in range(k):
        row_best = min(row_best, best_f[idx[i]])
    for i in range(k):
        if best_f[idx[i]] > row_best * (1.0 + _PRUNE_REL) + _PRUNE_ABS:
            active[i] = False
        for c in range(3):
            cells[i, c] = np.floor(best_p[idx[i], c] / _SAME)
    for i in range(k):
        a = idx[i]
        if not active[i]:
            continue
        for j in range(k):
            b = idx[j]
            if j == i or not active[j] or sid[b] != sid[a]:
                continue
            if not (best_f[b] < best_f[a] or (best_f[b] == best_f[a] and j < i)):
                continue
            if cells[j, 0] == cells[i, 0] and cells[j, 1] == cells[i, 1] \
                    and cells[j, 2] == cells[i, 2]:
                active[i] = False
                break


@nb.njit(cache=True, _nrt=False)
def _refine_row(G, M, r, idx, sid, hmin, best_uv, best_f, best_p, h, radius, walked, evals,
                iterations, bt, sc, flags, cells):
    """All iterations of row r's starts `idx` (ascending): each active start takes a `_step`,
    the point it picked is evaluated exactly, and a lower value becomes its best and its model's
    centre; the stencil then follows the step or shrinks, the walk's radii adapt, and a start
    whose stencil reached 2 hmin (both parameters) has converged. From _PRUNE_AFTER on, starts
    are `_pruned` before each step. `flags`, `cells`: scratch of at least len(idx) rows."""
    d, uv0, _, _, dom, _, _ = M
    k = idx.shape[0]
    active = flags[:k]
    active[:] = True
    for it in range(iterations):
        if it >= _PRUNE_AFTER:
            _pruned(best_f, best_p, sid, idx, active, cells)
        if not active.any():
            return
        for i in range(k):
            if not active[i]:
                continue
            s = idx[i]
            sd = sid[s]
            st = _step(M, s, r, sd, best_uv, best_f, best_p, h, radius, walked, sc)
            bt.sid[0], bt.u[0], bt.v[0] = sd, st.u, st.v
            _exact(G, M, r, 1, bt)  # a constant: the one point's loops unrolled
            evals[s] += st.probes + 1
            won = bt.size[0] < best_f[s]
            for c in range(2):
                lo, hi = dom[sd, c, 0], dom[sd, c, 1]
                centre = min(max(best_uv[s, c], lo + h[s, c]), hi - h[s, c])
                if won and (st.newton or st.along):  # the stencil follows the step
                    reach = (_REACH if st.along else 1.0) * h[s, c]
                    new = min(max(2.0 * abs((bt.u[0], bt.v[0])[c] - centre), 0.125 * h[s, c]),
                              reach)
                else:
                    new = (0.25 if st.centre else 0.5) * h[s, c]
                h[s, c] = min(max(new, hmin[s, c]), 0.25 * (hi - lo))
            if won:
                moved = 0.0
                for c in range(3):
                    moved += (bt.ev[0, _POINT, c] - best_p[s, c]) ** 2
                if np.sqrt(moved) > _MOVED:  # a start that moved may walk again
                    radius[s, _R_TRUST] = abs(radius[s, _R_TRUST])
                best_f[s] = bt.size[0]
                best_uv[s, 0], best_uv[s, 1] = bt.u[0], bt.v[0]
                for c in range(3):
                    best_p[s, c] = bt.ev[0, _POINT, c]
                _centre(d, uv0, s, 0, bt)
                if st.walked and walked[s] >= 0.99 * radius[s, _R_REACH]:
                    radius[s, _R_REACH] = min(_GROW * radius[s, _R_REACH], radius[s, _R_CAP])
            elif st.walked:  # the model misled the walk: shorter walks
                radius[s, _R_REACH] = max(_SHRINK * walked[s], _DELTA)
            if h[s, 0] <= 2.0 * hmin[s, 0] and h[s, 1] <= 2.0 * hmin[s, 1]:
                active[i] = False  # converged


@nb.njit(cache=True)
def _refine_rows(G, M, rows, sid, order, bounds, hmin, best_uv, best_f, best_p, h, radius,
                 walked, evals, iterations, most, t, tasks):
    """The starts' first exact values and Taylor models, then `_refine_row`, for the rows
    g = t, t + tasks, ... (row g's starts are order[bounds[g]:bounds[g + 1]], ascending; `most`
    the largest such count), with scratch of its own. `radius` starts from the stencil's
    half-width (mm)."""
    d, uv0, _, _, _, _, _ = M
    bt, sc = point_batch(most, 6), _step_scratch()
    flags, cells = np.empty(most, dtype=np.bool_), np.empty((most, 3))
    for g in range(t, bounds.shape[0] - 1, tasks):
        idx = order[bounds[g]:bounds[g + 1]]
        r = rows[idx[0]]
        for i in range(idx.shape[0]):
            s = idx[i]
            bt.sid[i], bt.u[i], bt.v[i] = sid[s], best_uv[s, 0], best_uv[s, 1]
        _exact(G, M, r, idx.shape[0], bt)
        for i in range(idx.shape[0]):
            s = idx[i]
            best_f[s] = bt.size[i]
            best_uv[s, 0], best_uv[s, 1] = bt.u[i], bt.v[i]
            for c in range(3):
                best_p[s, c] = bt.ev[i, _POINT, c]
            _centre(d, uv0, s, i, bt)
            su, sv = _speeds(d, s)
            r0 = max(h[s, 0] * su, h[s, 1] * sv)
            radius[s, _R_TRUST], radius[s, _R_REACH] = r0, _REACH * r0
            radius[s, _R_CAP] = max(_RADIUS_CAP * r0, _CAP_MM)
        _refine_row(G, M, r, idx, sid, hmin, best_uv, best_f, best_p, h, radius, walked, evals,
                    iterations, bt, sc, flags, cells)


@nb.njit(cache=True, parallel=True)
def _refine_all(G, d, uv0, Q, floor, dom, sz, T, rows, sid, order, bounds, hmin, best_uv,
                best_f, best_p, h, radius, walked, evals, iterations, most):
    """`_refine_rows` over _TASKS parallel tasks, the rows interleaved so that both threads get
    a share of the rows that take long; the `_Model` passed field by field (a tuple holding
    `sz` cannot enter a parallel loop)."""
    tasks = min(bounds.shape[0] - 1, _TASKS)
    for t in nb.prange(tasks):
        _refine_rows(G, _Model(d, uv0, Q, floor, dom, sz, T), rows, sid, order, bounds, hmin,
                     best_uv, best_f, best_p, h, radius, walked, evals, iterations, most,
                     np.int64(t), tasks)


def refine(part: Part, cutter, frame: RowFrame, Q: np.ndarray, rows: np.ndarray, sid: np.ndarray,
           uv: np.ndarray, step: np.ndarray, iterations: int = 8) -> Refined:
    """Refine S starts: `rows (S,)` CC rows of `frame` (tool frames `Q (N, 3, 3)`, one per row),
    `sid (S,)` surfaces, `uv (S, 2)` start parameters, `step (S, 2)` initial stencil half-widths
    in parameter units. One compiled call: the rows' starts refined in parallel (`_refine_all`)."""
    obj = Objective(part, cutter, frame, Q)
    n = len(rows)
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    sid = np.ascontiguousarray(sid, dtype=np.int64)
    lo, hi = obj.dom[sid, :, 0], obj.dom[sid, :, 1]
    width = hi - lo
    hmin = np.maximum(1e-10 * np.maximum(width, 1e-300), _CONVERGED * step)
    best_uv = np.clip(uv, lo, hi)
    h = np.clip(step, hmin, 0.25 * width)
    best_f, best_p = np.empty(n), np.empty((n, 3))
    evals = np.ones(n, dtype=np.int64)
    if n:
        order = np.argsort(rows, kind="stable")
        starts = np.flatnonzero(np.diff(rows[order])) + 1
        bounds = np.concatenate([[0], starts, [n]]).astype(np.int64)
        _refine_all(obj.G, np.empty((n, 6, 3)), np.empty((n, 2)), obj.Q, obj.floor,
                     obj.dom, obj.sz, obj.trims, rows, sid, order, bounds, hmin, best_uv, best_f,
                     best_p, h, np.empty((n, 3)), np.zeros(n), evals, iterations,
                     int(np.diff(bounds).max()))
    return Refined(best_f, best_uv, best_p, evals)
