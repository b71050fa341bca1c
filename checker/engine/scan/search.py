"""The global scan: the exact minimum of the imaginary size over all test points of the part
per CC row, with sound pruning (grid/family.py), then up to m seed points per row in distinct basins
for the local refinement. Tool frame of each row, mm.

The result is that of a plain growing scan: trial sizes s_goal, 4 s_goal, ... (capped at s_cap;
s_goal = s_start kept within [_MIN_TRIAL_MM, s_cap]) until the smallest size B over the
candidates C(s) of a trial (the test points of the region where a size <= s can lie, grown by
the slack; grid/candidates.py) is <= s, at the trial size G(B). The seeds are the sampled local
minima (basins.py) up to the limit L(B) = (1 + rel) B + slack among C(G); the contour crossings
(contour.py) come from C(G). As C(s) holds every point of size <= s, when G >= L the seeds are
those among all points up to L.

This scan gets there from fewer evaluations. Each row first gets an upper bound u >= B: every
`_ANCHOR_STEP`-th row from a coarse sample of its region, the rows between from the minima of
the two anchors around them (bound.py). One pass (sweep.py) then takes the candidates C(G(u))
(C(min(G(u), L(u))) without crossings) and evaluates only those in the region of L(u) grown
by `_EVAL_MARGIN_MM` alone, which holds every point of size <= L(u): that finds B, and the
row's result unless G(B) < L(B) or crossings are wanted, and G(B) != G(u); then a pass at
G(B) and L(B) gives it. Rows without a bound take a pass at s_cap. Rows that no cutter of the
family can touch (every size 0: no sound region) take the plain growing scan itself.
(docs/MATH.md §5.2)

Rows of many tool axes (`binned_scan`) take one scan per bin of nearby axes, each on the cell
grid of its bin (grid/bins.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from checker.engine.grid.bins import axis_bins, tool_grid
from checker.engine.grid.candidates import CellGrid, region_rows
from checker.engine.grid.rotations import identity_rows
from checker.engine.scan.bound import Bounds, coarse_bounds, warm_bounds
from checker.engine.scan.contour import ContourSeeds, Crossings, EdgeData, edge_data
from checker.engine.scan.sweep import Minima, Scan, sweep
from checker.engine.sizes import RowFrame, size_args, untouchable
from checker.geometry.sampling import TestPoints

_GROW = 4.0
_REL_MARGIN = 0.05
_ANCHOR_STEP = 8  # every this many rows one is scanned first; the others start from its minima
_EVAL_MARGIN_MM = 1e-6  # growth of the evaluated region against rounding
_MIN_TRIAL_MM = 1e-3  # the smallest first trial size: a start at 0 (a neighbour of size 0)
# would never grow


def _ladder(x: np.ndarray, s_goal: np.ndarray, s_cap: float) -> np.ndarray:
    """(N,) the first of the trial sizes s_goal, 4 s_goal, ... (each capped at s_cap) that is
    >= x (mm): where the plain growing scan stops for a row of minimum x; inf where x > s_cap."""
    g = s_goal.copy()
    up = (g < x) & (g < s_cap)
    while up.any():
        g[up] = np.minimum(g[up] * _GROW, s_cap)
        up = (g < x) & (g < s_cap)
    return np.where(g >= x, g, np.inf)


@dataclass
class _Rows:
    """What every pass over the rows of one scan shares."""

    cutter: object
    frame: RowFrame
    grid: CellGrid
    rot: np.ndarray
    slack: float
    m: int
    knn: np.ndarray
    crossings: ContourSeeds | None
    edges: EdgeData | None

    def region(self, rows: np.ndarray, s: np.ndarray, margin: float) -> np.ndarray:
        """Region arrays (grid/candidates.py) of finite trial sizes `s` (mm) for `rows`, every bound
        grown by `margin` mm."""
        fr = self.frame
        plane = np.column_stack([fr.n[rows], np.einsum("ij,ij->i", fr.n[rows], fr.cc[rows])
                                 - margin])
        return region_rows(self.grid, fr.fam.take(rows), s, margin, plane, self.rot[rows])

    def run(self, rows: np.ndarray, s_p: np.ndarray, s_e: np.ndarray) -> Scan:
        """A pass over `rows` with the candidates C(s_p), evaluating those in the region of s_e
        grown by `_EVAL_MARGIN_MM` (all candidates where s_e is inf)."""
        reg = self.region(rows, s_p, self.slack)
        lim = reg.copy()
        some = np.isfinite(s_e)
        lim[some] = self.region(rows[some], s_e[some], _EVAL_MARGIN_MM)
        return sweep(self.grid, self.rot[rows], reg, lim, size_args(self.cutter, self.frame, rows),
                     self.knn, self.m, _REL_MARGIN, self.slack, self.crossings, self.edges)

    def coarse(self, rows: np.ndarray, s: np.ndarray) -> Bounds:
        """Upper bounds of the rows' minima from the region of trial sizes `s` (bound.py)."""
        return coarse_bounds(self.grid, self.rot[rows], self.region(rows, s, self.slack),
                             size_args(self.cutter, self.frame, rows), self.knn)

    def warm(self, rows: np.ndarray, starts: np.ndarray) -> Bounds:
        """Upper bounds of the rows' minima from start points `starts (N, S)` (bound.py)."""
        return warm_bounds(self.grid.xyz, self.rot[rows], starts,
                           size_args(self.cutter, self.frame, rows), self.knn)


class _State:
    """Per-row progress of one scan: the result so far, the bound u >= B, B once found, the next
    trial of the plain growing scan, and the rows still open."""

    def __init__(self, ctx: _Rows, s_start: np.ndarray, s_cap: float):
        n, m = len(s_start), ctx.m
        self.ctx, self.s_cap = ctx, s_cap
        self.out = Minima.empty(n, m)
        self.s_goal = np.clip(np.nan_to_num(s_start, nan=s_cap), _MIN_TRIAL_MM, s_cap)
        self.rung = self.s_goal.copy()  # next trial of the plain scan
        self.u = np.full(n, np.inf)
        self.low = np.full(n, np.nan)  # B, once found
        self.plain = untouchable(ctx.cutter, ctx.frame.n)  # these take the plain scan only
        self.open = np.ones(n, dtype=bool)
        self.cross: list[Crossings] = []

    def settle(self, rows: np.ndarray, p: Scan, s_p: np.ndarray, s_e: np.ndarray,
               sure: np.ndarray | bool = False) -> None:
        """Take a pass over `rows` with candidates C(s_p), evaluated up to s_e (inf: all), that
        was `sure` to find the minimum (from a bound): store the rows it completes (module
        docstring)."""
        out, slack, found = self.out, self.ctx.slack, p.minima
        out.evaluations[rows] += found.evaluations
        b = found.best
        upto = np.minimum(s_p, s_e)
        got = b <= upto  # then b is the row's minimum B
        self.u[rows] = np.minimum(self.u[rows], b)
        self.low[rows[got]] = b[got]
        g = _ladder(b, self.s_goal[rows], self.s_cap)
        limit = b * (1.0 + _REL_MARGIN) + slack
        # complete where the pass evaluated every point the result depends on: those up to
        # L(B) among C(G(B)) (a pass at s_p = G(B)), or those up to L(B) among all points where
        # G(B) >= L(B) and no crossings are wanted; a plain row at its first trial that finds B
        at_g = s_p == g
        among_all = (self.ctx.crossings is None) & (g >= limit) & (s_p >= limit)
        plain = self.plain[rows]
        done = got & (plain | ((s_e >= limit) & (at_g | among_all)))
        r = rows[done]
        out.best[r], out.arg[r] = b[done], found.arg[done]
        out.seeds[r], out.seed_size[r] = found.seeds[done], found.seed_size[done]
        if p.crossings is not None:
            self.cross.append(p.crossings.where(done[p.crossings.rows]).renumbered(rows))
        self.open[r] = False
        self.open[rows[~got & (upto >= self.s_cap)]] = False  # nothing up to s_cap: unbounded
        up = ~got & plain  # a failed trial of the plain scan
        self.rung[rows[up]] = np.minimum(s_p[up] * _GROW, self.s_cap)
        # a bound that did not hold (impossible with sound regions) leaves the row to the plain
        # scan
        self.plain[rows[~got & sure & (upto < self.s_cap)]] = True

    def step(self, rows: np.ndarray) -> None:
        """One pass over the open `rows`: plain rows take the plain scan's next trial, rows with
        a bound x (or B) the candidates of G(x) evaluated up to L(x), the others everything up
        to s_cap."""
        x = np.where(np.isnan(self.low[rows]), self.u[rows], self.low[rows])
        x = np.where(x <= self.s_cap, x, np.nan)
        s_e = np.where(np.isnan(x), self.s_cap, x * (1.0 + _REL_MARGIN) + self.ctx.slack)
        s_p = np.where(np.isnan(x), self.s_cap, _ladder(x, self.s_goal[rows], self.s_cap))
        if self.ctx.crossings is None:
            s_p = np.minimum(s_p, s_e)
        plain = self.plain[rows]
        s_p[plain], s_e[plain] = self.rung[rows[plain]], np.inf
        self.settle(rows, self.ctx.run(rows, s_p, s_e), s_p, s_e, ~np.isnan(x) & ~plain)

    def finish(self, rows: np.ndarray) -> None:
        """Passes over `rows` until all are complete."""
        rows = rows[self.open[rows]]
        while rows.size:
            self.step(rows)
            rows = rows[self.open[rows]]

    def add_bounds(self, rows: np.ndarray, bound: Callable[[np.ndarray], Bounds]) -> None:
        """Lower the bounds of `rows` by `bound(rows)`."""
        if rows.size:
            found = bound(rows)
            self.u[rows] = np.minimum(self.u[rows], found.upper)
            self.out.evaluations[rows] += found.evaluations


def scan(cutter, frame: RowFrame, grid: CellGrid, s_start: np.ndarray, s_cap: float,
         slack: float, m: int, knn: np.ndarray, crossings: ContourSeeds | None = None,
         rot: np.ndarray | None = None, first: np.ndarray | None = None) -> Scan:
    """Exact sampled minimum per row, the minimum over all test points up to `s_cap` (beyond it
    the row is unbounded), with its seeds, those of a growing scan from the finite trial sizes
    `s_start (N,)` (module docstring). `crossings`: also that many bottom-plane contour
    crossings per row (contour.py) from the candidates C(G).
    `rot (N, 3, 3)`: each row's tool frame seen from the grid's (default: the grid's frame).
    `first (N,)`: a first trial size per row, tried before anything else: the points up to it
    are evaluated, and rows whose minimum is far enough below it finish there (cheap where the
    minima are small); the result does not depend on it."""
    n = len(s_start)
    rot = identity_rows(n) if rot is None else np.ascontiguousarray(rot)
    edges = None if crossings is None else edge_data(grid, knn)
    ctx = _Rows(cutter, frame, grid, rot, slack, m, knn, crossings, edges)
    st = _State(ctx, s_start, s_cap)
    rows = np.arange(n)
    if first is not None:
        some = rows[~st.plain]
        s1 = np.minimum(first[some], st.s_goal[some])
        st.settle(some, ctx.run(some, s1, s1), s1, s1)
    todo = rows[st.open & np.isnan(st.low) & ~st.plain]

    def coarse(r: np.ndarray) -> Bounds:
        return ctx.coarse(r, np.minimum(st.u[r], s_cap))

    anchors = todo[::_ANCHOR_STEP]
    st.add_bounds(anchors, coarse)
    st.finish(anchors)
    rest = np.setdiff1d(todo, anchors)
    if rest.size:
        k = np.searchsorted(anchors, rest)  # the anchors on either side
        near = np.column_stack([anchors[np.maximum(k - 1, 0)],
                                anchors[np.minimum(k, len(anchors) - 1)]])
        starts = np.concatenate([st.out.arg[near], st.out.seeds[near].reshape(len(rest), -1)],
                                axis=1)
        st.add_bounds(rest, lambda r: ctx.warm(r, starts))
        st.add_bounds(rest[~np.isfinite(st.u[rest])], coarse)
    st.finish(rows)
    return Scan(st.out, Crossings.join(st.cross) if st.cross else None)


def binned_scan(tp: TestPoints, cutter, frame: RowFrame, Q: np.ndarray, axes: np.ndarray,
                s_start: np.ndarray, s_cap: float, slack: float, m: int, knn: np.ndarray,
                crossings: ContourSeeds | None = None,
                first: np.ndarray | None = None) -> Scan:
    """`scan` for rows of any tool axes `axes (N, 3)` (part frame, unit) with tool frames
    `Q (N, 3, 3)`, one scan per bin of nearby axes (`first`: see `scan`); the merged result."""
    out = Minima.empty(len(s_start), m)
    cross: list[Crossings] = []
    for b in axis_bins(axes, Q):
        rows = b.rows
        sub = RowFrame(frame.cc[rows], frame.n[rows], frame.e[rows], frame.fam.take(rows),
                       frame.exclusion)
        sc = scan(cutter, sub, tool_grid(tp, b.axis, b.rotation), s_start[rows], s_cap, slack, m,
                  knn, crossings, rot=b.relative, first=None if first is None else first[rows])
        found = sc.minima
        out.best[rows], out.arg[rows], out.evaluations[rows] = (found.best, found.arg,
                                                                found.evaluations)
        out.seeds[rows], out.seed_size[rows] = found.seeds, found.seed_size
        if sc.crossings is not None:
            cross.append(sc.crossings.renumbered(rows))
    return Scan(out, Crossings.join(cross) if cross else None)
