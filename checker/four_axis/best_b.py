"""The best table angle per CC point: B* = argmax over B of min over test points of R(P; B)
(thesis eq. 2.2, chapter 5), and the feasible B intervals for the real cutter.

Works on any `allowable_fn(point_index (M,), b_deg (M,)) -> sizes (M,)` (mm, inf = unbounded), so
the engine evaluates many (point, B) rows as one batch. A coarse scan over the machine's B range,
then a vectorised golden-section refinement around the best few local maxima of every point
(to `b_tolerance` degrees), and a vectorised refinement of every interval end (`_refine_ends`).
Degrees throughout.

With a cheap upper bound of the scan's function (`bound_fn`, e.g. the engine's size at a few
hundred test points and a descent from them), rows that cannot matter are not evaluated: a scan
sample whose bound is below `required` and below the point's top by more than the plateau is
infeasible and no top, so neither the intervals, nor the top, nor a flat top, nor the optimum
of an interval change when the bound stands in for it (a lower sample only moves a crossing
that the refinement of the ends replaces, which only feasible sizes steer); an end's probe
whose bound is below the level is on the infeasible side. Every answer is the one without the
bound. (The golden section gains
little from it: its probes lie near the top, where the bound is seldom below the point a
probe is compared with. Brent's parabolic steps do not suit it either: A(B) is a minimum over
test points, often with a kink or several small maxima in the bracket, so they fall back to
golden steps and end at other local maxima. What pays is tracking where the size is limited:
near the top of A(B) the limiting points move little, so the section runs on the sizes refined
from them, far cheaper than the engine, and the engine confirms the result
(`_golden_tracked`). The interval ends are of two kinds: where the CC point turns away from the
axis, A(B) near its top up to there and 0 past it, which the closed-form edge (`edge_fn`)
settles with one probe; and where A(B) falls off smoothly, which probes either side of where
the parabola through the last three feasible B meets the level settle in a round or two, in
fewer probes than bisection. CHANGELOG.md has the measured counts.)
(docs/MATH.md §7.1, §5.3)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import NamedTuple, Protocol

import numpy as np

from checker.four_axis.intervals import Intervals, feasible_intervals
from checker.progress import step

AllowableFn = Callable[[np.ndarray, np.ndarray], np.ndarray]
# (point_index (M,), inside (M,), outside (M,)) -> (M,) degrees: a B between the two past which
# the function is 0 up to `outside` (nan: none), e.g. where the point turns away from the axis
EdgeFn = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
PLATEAU = 1e-6  # mm: coarse samples this close to the top make a flat top
COARSE_PLATEAU = 1e-3  # mm: the same for a coarse evaluation (a cheaper upper bound)
END_TOLERANCE = 0.2  # degrees: the feasible intervals' ends, kept on the feasible side
_SCAN_BATCH = 10_000  # (point, B) rows per engine call of the coarse scan
_TRACKED_PASSES = 3  # sections on tracked limiting points before the section of the engine
_LINE_STEP = 0.45  # the ends' probes this many tolerances either side of the crossing


class Limited(NamedTuple):
    """The engine's sizes at (point, B) rows, `size (M,)` mm, and where each was limited: on
    `surface (M,)` (-1: nowhere) at `uv (M, 2)`."""

    size: np.ndarray
    surface: np.ndarray
    uv: np.ndarray

    @staticmethod
    def nowhere(n: int) -> Limited:
        """n rows of size 0, limited nowhere (to be filled)."""
        return Limited(np.zeros(n), np.full(n, -1, np.int64), np.full((n, 2), np.nan))


class Tracked(Protocol):
    """The engine over B with the points that limit its sizes (`four_axis.over_b.OverB`)."""

    def sizes(self, rows: np.ndarray, b_deg: np.ndarray) -> np.ndarray: ...

    def limited(self, rows: np.ndarray, b_deg: np.ndarray,
                hint: np.ndarray | None = None) -> Limited: ...

    def near(self, rows: np.ndarray, b_deg: np.ndarray, surface: np.ndarray,
             uv: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class BestB:
    """Per point: best B and the allowable size there, the feasible intervals, and the coarse
    samples (grid (K,), sizes (N, K), mm) they came from (a sample skipped by `bound_fn` holds
    its bound: below `required` and below the point's top)."""

    b_best: np.ndarray
    allowable_at_best: np.ndarray
    feasible: list[Intervals]
    grid: np.ndarray
    samples: np.ndarray


def coarse_grid(b_min: float, b_max: float, step: float) -> np.ndarray:
    """Evenly spaced B values covering [b_min, b_max] with spacing <= step, degrees."""
    count = max(2, int(np.ceil((b_max - b_min) / step - 1e-9)) + 1)
    return np.linspace(b_min, b_max, count)


def _scan(fn: AllowableFn, n: int, grid: np.ndarray, bound: AllowableFn | None = None,
          skip_below: np.ndarray | None = None, plateau: float = 0.0) -> np.ndarray:
    """fn over every (point, grid B), (n, K): the grid's columns in batches of about
    _SCAN_BATCH rows, one after the other (the engine's kernels use every core themselves).
    With `bound` (an upper bound of fn, mm): first fn at each point's column of the largest
    bound; then a sample whose bound is below `skip_below (n,)` and more than `plateau` below
    the largest sample so far keeps its bound instead of fn (module docstring); fn takes the
    bounds as its hints (`hint=`: sizes expected, which only its time depends on)."""
    rows = np.tile(np.arange(n), grid.size)  # column by column: the rows of one B together
    b = np.repeat(grid, n)
    if bound is None:
        return _batched(fn, rows, b, "best B: scan of the B range").reshape(grid.size, n).T
    out = _batched(bound, rows, b, "best B: bounds over the B range").reshape(grid.size, n).T.copy()
    points = np.arange(n)
    first = np.argmax(out, axis=1)
    top = fn(points, grid[first], hint=out[points, first])
    exact = (out >= skip_below[:, None]) | (out >= (top - plateau)[:, None])
    exact[points, first] = False
    out[points, first] = top
    k, i = np.nonzero(exact.T)
    out[i, k] = _batched(fn, i, grid[k], "best B: scan of the B range", hint=out[i, k])
    return out


def _batched(fn: AllowableFn, rows: np.ndarray, b: np.ndarray, what: str,
             hint: np.ndarray | None = None) -> np.ndarray:
    """fn(rows, b) in batches of about _SCAN_BATCH rows, with progress; with `hint`, each
    batch's hints (`hint=`, mm)."""
    parts = []
    cuts = range(0, rows.size, _SCAN_BATCH)
    with step(what, total=len(cuts)) as advance:
        for a in cuts:
            at = slice(a, a + _SCAN_BATCH)
            parts.append(fn(rows[at], b[at]) if hint is None
                         else fn(rows[at], b[at], hint=hint[at]))
            advance(1)
    return np.concatenate(parts) if parts else np.zeros(0)


def _rounds(width: float, tol: float, shrink: float) -> int:
    """Rounds that shrink `width` by `shrink` each until it is at most `tol` (the steps'
    totals)."""
    return max(0, int(np.ceil(np.log(tol / width) / np.log(shrink)))) if width > tol else 0


def _top_local_maxima(samples: np.ndarray, count: int) -> np.ndarray:
    """Column indices (N, count) of the largest local maxima of each row (repeats when fewer)."""
    padded = np.pad(samples, ((0, 0), (1, 1)), constant_values=-np.inf)
    is_peak = (samples >= padded[:, :-2]) & (samples >= padded[:, 2:])
    score = np.where(is_peak, samples, -np.inf)
    order = np.argsort(-score, axis=1, kind="stable")[:, :count]
    first = order[:, :1]
    valid = np.take_along_axis(score, order, axis=1) > -np.inf
    return np.where(valid, order, first)


def _unless_below(fn: AllowableFn, bound: AllowableFn | None, rows: np.ndarray, b: np.ndarray,
                  against: np.ndarray) -> np.ndarray:
    """fn(rows, b), but where `bound` (an upper bound of fn) is below `against` (mm, per row):
    the bound itself (then fn is below `against` too); elsewhere the bound is fn's hint."""
    if bound is None:
        return fn(rows, b)
    out = bound(rows, b)
    need = out >= against
    if need.any():
        out[need] = fn(rows[need], b[need], hint=out[need])
    return out


def _golden_max(fn: AllowableFn, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray, tol: float,
                inner: tuple[np.ndarray, np.ndarray] | None = None):
    """Vectorised golden-section search for the maximum of fn(row, b) on [lo, hi] per row
    (`inner`: the values at the two inner points, when known)."""
    a, b = lo.copy(), hi.copy()
    c = b - GOLDEN * (b - a)
    d = a + GOLDEN * (b - a)
    fc, fd = (fn(rows, c), fn(rows, d)) if inner is None else inner
    with step("best B: refinement", total=_rounds(float(np.max(b - a)), tol, GOLDEN)) as advance:
        while np.max(b - a) > tol:
            left = fc >= fd  # keep [a, d]
            b = np.where(left, d, b)
            a = np.where(left, a, c)
            new_c = b - GOLDEN * (b - a)
            new_d = a + GOLDEN * (b - a)
            probe = np.where(left, new_c, new_d)
            fp = fn(rows, probe)
            c, fc, d, fd = (
                np.where(left, new_c, d),
                np.where(left, fp, fd),
                np.where(left, c, new_d),
                np.where(left, fc, fp),
            )
            advance(1)
    best_is_c = fc >= fd
    return np.where(best_is_c, c, d), np.where(best_is_c, fc, fd)


def _golden_tracked(tracked: Tracked, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                    tol: float, near_top: np.ndarray):
    """`_golden_max` of the engine's A(B) (`tracked.limited`) from 3 of its evaluations per
    row instead of 17: the section runs on g(B), the sizes refined from the points where A was
    limited at the bracket's two inner points (`tracked.near`: sizes at surface points, so
    g >= the true minimum), then A is evaluated at the section's best B*. Where A(B*) >=
    g(B*) - PLATEAU, B* is as good as a section of A: A(B*) >= g(B*) >= g(B) >= A(B) over the
    bracket (for the maximiser the section finds); elsewhere the point where A(B*) was limited
    joins the tracked ones for another pass, and after _TRACKED_PASSES the section of A itself
    decides. The size reported is min(A(B*), g(B*)): g lies below A where the engine's own
    search missed a minimum that a tracked point leads to (docs/MATH.md §7.1). `near_top (M,)`
    mm: the scan's size at each row's peak, the first two evaluations' hint (time only)."""
    c, d = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    seen = [tracked.limited(rows, c, hint=near_top), tracked.limited(rows, d, hint=near_top)]
    b_out, f_out = np.empty(rows.size), np.empty(rows.size)
    todo = np.arange(rows.size)
    for _ in range(_TRACKED_PASSES):
        near = partial(tracked.near, surface=np.column_stack([e.surface[todo] for e in seen]),
                       uv=np.stack([e.uv[todo] for e in seen], axis=1))
        b_star, g_star = _golden_max(near, rows[todo], lo[todo], hi[todo], tol,
                                     (seen[0].size[todo], seen[1].size[todo]))
        at = tracked.limited(rows[todo], b_star)
        ok = at.size >= g_star - PLATEAU
        b_out[todo[ok]], f_out[todo[ok]] = b_star[ok], np.minimum(at.size, g_star)[ok]
        seen.append(_scattered(at, todo, rows.size))
        todo = todo[~ok]
        if not todo.size:
            return b_out, f_out
    b_out[todo], f_out[todo] = _golden_max(tracked.sizes, rows[todo], lo[todo], hi[todo], tol)
    return b_out, f_out


def _scattered(part: Limited, where: np.ndarray, n: int) -> Limited:
    """`part` placed at rows `where` of n rows; the others limited nowhere."""
    out = Limited.nowhere(n)
    out.size[where], out.surface[where], out.uv[where] = part
    return out


def _level_crossing(a, fa, p, fp, q, fq, o, level) -> np.ndarray:
    """(M,) the fraction of the way from `a` to `o` at which the parabola through the feasible
    (q, fq), (p, fp), (a, fa) (B beyond `a`, away from `o`) meets the level nearest `a`
    towards `o`; where q is nan or the parabola does not meet it that way, the line through
    the last two (fp > fa)."""
    with np.errstate(all="ignore"):
        slope = (fp - fa) / (p - a)
        bend = ((fq - fp) / (q - p) - slope) / (q - a)  # Newton's divided differences
        b1, c0 = slope - bend * (p - a), fa - level  # bend x^2 + b1 x + c0 = 0, x = B - a
        root = np.sqrt(b1 * b1 - 4.0 * bend * c0)
        half = -0.5 * (b1 + np.copysign(root, b1))
        t = np.column_stack([half / bend, c0 / half]) / (o - a)[:, None]
        t = np.where(t > 0.0, t, np.inf).min(axis=1)
        return np.where(np.isfinite(t), t, -c0 / slope / (o - a))


def _refine_ends(fn: AllowableFn, rows, inside, outside, f_in, before, f_before, level,
                 tol: float, bound: AllowableFn | None = None,
                 edge: EdgeFn | None = None) -> np.ndarray:
    """The boundary between a feasible B `inside` (size `f_in` >= level) and an infeasible
    one `outside`, to `tol` degrees, kept on the feasible side; `before (M, 2)`, `f_before
    (M, 2)`: the two B beyond `inside` (away from `outside`, the nearer first) and their sizes
    where feasible (nan: not). Where `edge` gives a B between them past which fn is 0 up to
    `outside`, that B replaces `outside` and the first probe is tol / 2 inside it (an end at
    the facing limit takes that one probe). Then, per row, rounds of probes either side of
    where the parabola through the last three feasible B (the line through the last two)
    meets the level (a smooth A(B) ends in a round of two probes) or, where the row's last
    such round did not halve its bracket or there is no such curve (a jump from near its top
    to 0), a bisection: at least a halving every two rounds. Only feasible sizes steer it, so
    a probe whose `bound` (an upper bound of fn) is below the level is infeasible without fn
    and every end is the one without the bound."""
    a, o, p, q = (inside.astype(float), outside.astype(float), before[:, 0].astype(float),
                  before[:, 1].astype(float))
    fa, fp, fq = f_in.astype(float), f_before[:, 0].astype(float), f_before[:, 1].astype(float)
    at_edge = np.zeros(rows.size, bool)
    if edge is not None and rows.size:
        e = edge(rows, a, o)
        at_edge = np.isfinite(e)
        o[at_edge] = e[at_edge]
    bisect = np.zeros(rows.size, bool)
    todo = np.flatnonzero(np.abs(o - a) > tol)
    with step("best B: feasible interval ends", total=rows.size) as advance:
        advance(rows.size - todo.size)
        while todo.size:
            width = np.abs(o[todo] - a[todo])
            t1, t2 = np.full(todo.size, 0.5), np.full(todo.size, np.nan)
            line = ~bisect[todo] & np.isfinite(fa[todo]) & np.isfinite(fp[todo]) \
                & (fp[todo] > fa[todo])
            r = todo[line]
            t = _level_crossing(a[r], fa[r], p[r], fp[r], q[r], fq[r], o[r], level[r])
            h = _LINE_STEP * tol / np.abs(o[r] - a[r])
            t1[line] = np.where((t - h > 0.0) & (t - h < 1.0), t - h, np.nan)
            t2[line] = np.where((t + h > 0.0) & (t + h < 1.0), t + h, np.nan)
            line &= np.isfinite(t1) | np.isfinite(t2)
            t1[~line], t2[~line] = 0.5, np.nan
            first = at_edge[todo]  # the probe tol / 2 inside the edge
            t1[first], t2[first] = 1.0 - 0.5 * tol / width[first], np.nan
            at_edge[todo] = False
            probes = np.column_stack([t1, t2])
            i, j = np.nonzero(np.isfinite(probes))
            r = todo[i]
            place = np.full(probes.shape, np.nan)
            place[i, j] = a[r] + probes[i, j] * (o[r] - a[r])
            value = np.full(probes.shape, np.nan)
            value[i, j] = _unless_below(fn, bound, rows[r], place[i, j], level[r])
            for k in range(2):  # from the inside out: feasible probes move a, the first other o
                b, v = place[:, k], value[:, k]
                live = np.isfinite(b) & (np.abs(o[todo] - a[todo]) >= np.abs(b - a[todo]))
                ok = live & (v >= level[todo])
                r = todo[ok]
                q[r], fq[r], p[r], fp[r], a[r], fa[r] = p[r], fp[r], a[r], fa[r], b[ok], v[ok]
                o[todo[live & ~ok]] = b[live & ~ok]
            bisect[todo] = line & (np.abs(o[todo] - a[todo]) > 0.5 * width)
            done = np.abs(o[todo] - a[todo]) <= tol
            advance(int(done.sum()))
            todo = todo[~done]
    return a


def _refined_intervals(fn, grid, samples, required, tol, bound=None,
                       edge: EdgeFn | None = None) -> list[Intervals]:
    coarse = feasible_intervals(grid, samples, required)
    step = grid[1] - grid[0]
    ends = [
        (row, j, side, value)
        for row, ivs in enumerate(coarse)
        for j, iv in enumerate(ivs)
        for side, value in enumerate(iv)
        if grid[0] + 1e-9 < value < grid[-1] - 1e-9
    ]
    if not ends:
        return coarse
    rows = np.array([e[0] for e in ends])
    side = np.array([e[2] for e in ends])
    value = np.array([e[3] for e in ends])
    # the coarse end lies between two grid samples: the feasible one and the infeasible one
    k = np.clip(np.searchsorted(grid, value), 1, grid.size - 1)
    k_in, k_out = np.where(side == 0, k, k - 1), np.where(side == 0, k - 1, k)
    inside, outside, f_in = grid[k_in], grid[k_out], samples[rows, k_in]
    far = np.abs(inside - value) > step
    inside, f_in = np.where(far, value, inside), np.where(far, np.nan, f_in)
    level = np.broadcast_to(np.asarray(required, float), (len(coarse),))[rows]
    # the two samples before the inside one: feasible ones steer the first probes (a skipped
    # sample holds its bound, below the level: infeasible either way)
    k_before = np.clip(k_in[:, None] + np.outer(k_in - k_out, [1, 2]), 0, grid.size - 1)
    f_before = samples[rows[:, None], k_before]
    f_before = np.where(f_before >= level[:, None], f_before, np.nan)
    refined = _refine_ends(fn, rows, inside, outside, f_in, grid[k_before], f_before, level,
                           tol, bound, edge)
    out = [list(ivs) for ivs in coarse]
    for (row, j, s, _), v in zip(ends, refined.tolist(), strict=True):
        lo, hi = out[row][j]
        out[row][j] = (v, hi) if s == 0 else (lo, v)
    return out


def best_b(
    fn: AllowableFn,
    n: int,
    *,
    b_min: float,
    b_max: float,
    coarse_step: float,
    tolerance: float,
    required: float | np.ndarray,
    reference: np.ndarray | None = None,
    candidates: int | None = None,
    coarse_fn: AllowableFn | None = None,
    bound_fn: AllowableFn | None = None,
    tracked: Tracked | None = None,
    edge_fn: EdgeFn | None = None,
) -> BestB:
    """Best B to `tolerance` degrees for n points, and their feasible intervals (ends to
    END_TOLERANCE) for a cutter that needs `required` mm. Unbounded and flat tops (the same size
    at several coarse samples) take the top sample nearest `reference` (the CAM's B).
    `coarse_fn`: a cheaper evaluation (an upper bound of `fn`) for the scan and the interval
    ends; the refinement and the size at the best B use `fn`. `bound_fn`: a still cheaper
    upper bound of the scan's function, to skip the rows that cannot matter (module docstring;
    in the scan only with one candidate peak, where only the top sample is refined).
    `tracked`: `fn` with the points that limit its sizes, for a refinement from far fewer of
    its evaluations (`_golden_tracked`). `edge_fn`: where the sizes drop to 0 (the point turns
    away from the axis), for the interval ends there (`_refine_ends`). Sizes known to lie near
    or above the ones asked for go to the evaluations as `hint=` (mm; only their time may
    depend on it): `coarse_fn`'s with `bound_fn` (the bounds), `fn`'s with `coarse_fn` (the
    scan's top at a flat top) and `tracked.limited`'s (the scan's peak), so those take it."""
    coarse = fn if coarse_fn is None else coarse_fn
    grid = coarse_grid(b_min, b_max, coarse_step)
    plateau = PLATEAU if coarse_fn is None else COARSE_PLATEAU
    if candidates is None:  # the best two local maxima, or the best one after a coarse scan
        candidates = 2 if coarse_fn is None else 1
    level = np.broadcast_to(np.asarray(required, float), (n,))
    samples = _scan(coarse, n, grid, bound_fn if candidates == 1 else None, level, plateau)
    reference = np.zeros(n) if reference is None else np.nan_to_num(reference, nan=0.0)
    b_best = np.empty(n)
    at_best = np.empty(n)
    unbounded = np.isinf(samples).any(axis=1)
    if unbounded.any():
        distance = np.where(np.isinf(samples), np.abs(grid[None, :] - reference[:, None]), np.inf)
        k = np.argmin(distance, axis=1)
        b_best[unbounded] = grid[k[unbounded]]
        at_best[unbounded] = np.inf
    top = samples.max(axis=1, keepdims=True)
    at_top = samples >= top - plateau
    flat = ~unbounded & (at_top.sum(axis=1) >= 2)
    if flat.any():
        # a flat top (the curvature limit, which no B changes): the top sample nearest the CAM's B
        distance = np.where(at_top, np.abs(grid[None, :] - reference[:, None]), np.inf)
        k = np.argmin(distance, axis=1)
        b_best[flat] = grid[k[flat]]
        at_best[flat] = top[flat, 0]
    bounded = np.flatnonzero(~unbounded & ~flat)
    if bounded.size:
        peaks = _top_local_maxima(samples[bounded], min(candidates, grid.size))
        rows = np.repeat(bounded, peaks.shape[1])
        k = peaks.ravel()
        step = grid[1] - grid[0]
        lo = np.maximum(grid[k] - step, b_min)
        hi = np.minimum(grid[k] + step, b_max)
        b_ref, f_ref = (_golden_max(fn, rows, lo, hi, tolerance) if tracked is None
                        else _golden_tracked(tracked, rows, lo, hi, tolerance, samples[rows, k]))
        f_ref = f_ref.reshape(-1, peaks.shape[1])
        b_ref = b_ref.reshape(-1, peaks.shape[1])
        pick = np.argmax(f_ref, axis=1)
        chosen_f = f_ref[np.arange(bounded.size), pick]
        chosen_b = b_ref[np.arange(bounded.size), pick]
        b_best[bounded], at_best[bounded] = chosen_b, chosen_f
        if coarse_fn is None:  # a grid sample can beat a refined peak only on the same scale
            coarse_best = samples[bounded].max(axis=1)
            use_grid = coarse_best > chosen_f
            b_best[bounded[use_grid]] = grid[np.argmax(samples[bounded[use_grid]], axis=1)]
            at_best[bounded] = np.maximum(chosen_f, coarse_best)
    if coarse_fn is not None:  # flat tops came from upper bounds: their exact size
        rows = np.flatnonzero(flat)
        at_best[rows] = fn(rows, b_best[rows], hint=top[rows, 0])
    feasible = _refined_intervals(coarse, grid, samples, required, max(tolerance, END_TOLERANCE),
                                  bound_fn, edge_fn)
    return BestB(b_best, at_best, feasible, grid, samples)
