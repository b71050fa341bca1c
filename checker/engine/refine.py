"""Batched local refinement in (u, v): every start (a CC row and a point on one surface) takes
the same few quadratic-model steps at once. Each step evaluates a 3x3 stencil, fits the
quadratic (central differences), takes the bounded Newton step when the model is convex (the
best stencil point otherwise), and shrinks the stencil as it converges. Steps stay inside the
surface domain; points outside a trim count as inf. The answer is the best point evaluated."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.cutter import BALL_FAMILY
from checker.engine.frames import heights, rotate_rows
from checker.engine.sizes import RowFrame, pair_sizes
from checker.geometry.evaluate import evaluate_mixed
from checker.part import Part

_ABOVE = 1e-9  # mm above the bottom plane: on it the kernels already count a point as uncut
_FLOOR_STEPS = 3
_FRACTIONS = np.array([1.0, 0.5, 0.25, 0.125])
_REACH = 4.0  # longest Newton step, stencil half-widths
_PRUNE_AFTER = 2  # iterations before starts far above their row's best are dropped
_PRUNE_REL, _PRUNE_ABS = 0.01, 0.02  # 'far above': more than 1 % + 0.02 mm
_CONVERGED = 1e-5  # a start stops when its stencil is this fraction of the initial one
_OFFS = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=np.float64)


@dataclass
class Refined:
    """Per start: `size (S,)` mm, `uv (S, 2)`, `point (S, 3)` part frame, `evaluations (S,)`."""

    size: np.ndarray
    uv: np.ndarray
    point: np.ndarray
    evaluations: np.ndarray


class _Objective:
    """Imaginary size of surface points (surface id, u, v) for given rows; trims honoured.

    Flat-bottomed cutters (R family, psi = 0) cut nothing below their bottom plane, so the
    size jumps to inf there and the minimum often lies on the contour line of the part at that
    height. Points below it are moved onto the contour (Newton steps on the height in (u, v)),
    which turns that jump into a smooth boundary the local steps can follow. `Q (N, 3, 3)`: the
    rotation part frame -> tool frame of every row of `frame`."""

    def __init__(self, part: Part, cutter, frame: RowFrame, Q: np.ndarray) -> None:
        self.part, self.cutter, self.frame, self.Q = part, cutter, frame, Q
        self.trimmed = [s.id for s in part.surfaces if s.trim is not None]
        self.dom = np.array([s.domain for s in part.surfaces], dtype=np.float64)
        flat = cutter.kind not in BALL_FAMILY and float(cutter.psi) == 0.0
        self.floor = frame.fam.z0 + _ABOVE if flat else None

    def __call__(self, rows, sid, u, v):
        """(f (K,), points (K, 3) part frame, uv (K, 2) of the points)."""
        u, v = u.copy(), v.copy()
        ev = evaluate_mixed(self.part, sid, u, v)
        if self.floor is not None:
            self._onto_floor(rows, sid, u, v, ev)
        f = pair_sizes(self.cutter, self.frame, rows, rotate_rows(self.Q, ev.points, rows))
        for s in self.trimmed:
            sel = np.flatnonzero(sid == s)
            if sel.size:
                out = ~np.asarray(self.part.surfaces[s].trim.contains(u[sel], v[sel]), dtype=bool)
                f[sel[out]] = np.inf
        return f, ev.points, np.column_stack([u, v])

    def _onto_floor(self, rows, sid, u, v, ev) -> None:
        """Move points below their row's bottom plane onto it (in place: u, v, ev)."""
        for _ in range(_FLOOR_STEPS):
            z = heights(self.Q, ev.points, rows)
            low = np.flatnonzero(z < self.floor[rows])
            if low.size == 0:
                return
            gu, gv = heights(self.Q, ev.du[low], rows[low]), heights(self.Q, ev.dv[low], rows[low])
            g2 = gu * gu + gv * gv
            ok = g2 > 1e-24
            low, gu, gv, g2 = low[ok], gu[ok], gv[ok], g2[ok]
            t = (self.floor[rows[low]] - z[low]) / g2
            d = self.dom[sid[low]]
            u[low] = np.clip(u[low] + t * gu, d[:, 0, 0], d[:, 0, 1])
            v[low] = np.clip(v[low] + t * gv, d[:, 1, 0], d[:, 1, 1])
            sub = evaluate_mixed(self.part, sid[low], u[low], v[low])
            ev.points[low], ev.du[low], ev.dv[low] = sub.points, sub.du, sub.dv


def refine(part: Part, cutter, frame: RowFrame, Q: np.ndarray, rows: np.ndarray, sid: np.ndarray,
           uv: np.ndarray, step: np.ndarray, iterations: int = 8) -> Refined:
    """Refine S starts: `rows (S,)` CC rows of `frame` (tool frames `Q (N, 3, 3)`, one per row),
    `sid (S,)` surfaces, `uv (S, 2)` start parameters, `step (S, 2)` initial stencil half-widths
    in parameter units."""
    obj = _Objective(part, cutter, frame, Q)
    dom = np.array([part.surfaces[s].domain for s in range(len(part.surfaces))], dtype=np.float64)
    lo, hi = dom[sid, :, 0], dom[sid, :, 1]
    width = hi - lo
    hmin = np.maximum(1e-10 * np.maximum(width, 1e-300), _CONVERGED * step)
    cur = np.clip(uv, lo, hi)
    f, pts, cur = obj(rows, sid, cur[:, 0], cur[:, 1])
    best_f, best_uv, best_p = f.copy(), cur.copy(), pts.copy()
    h = np.clip(step, hmin, 0.25 * width)
    evals = np.ones(len(rows), dtype=np.int64)
    active = np.ones(len(rows), dtype=bool)
    nrow = int(rows.max()) + 1 if rows.size else 0
    for it in range(iterations):
        if it >= _PRUNE_AFTER:  # drop starts clearly above the best of their row
            row_best = np.full(nrow, np.inf)
            np.minimum.at(row_best, rows, best_f)
            rb = row_best[rows]
            active &= ~(best_f > rb * (1.0 + _PRUNE_REL) + _PRUNE_ABS)
        a = np.flatnonzero(active)
        if a.size == 0:
            break
        ha, la, ua = h[a], lo[a], hi[a]
        c = np.clip(best_uv[a], la + ha, ua - ha)
        UV = (c[:, None, :] + _OFFS[None] * ha[:, None, :]).reshape(-1, 2)
        F, P, UV = obj(np.repeat(rows[a], 9), np.repeat(sid[a], 9), UV[:, 0], UV[:, 1])
        F, P, UV = F.reshape(-1, 9), P.reshape(-1, 9, 3), UV.reshape(-1, 9, 2)
        ar = np.arange(a.size)
        k = np.where(F[:, 4] <= F.min(axis=1), 4, np.argmin(F, axis=1))
        _keep_best(best_f, best_uv, best_p, a, F[ar, k], UV[ar, k], P[ar, k])
        g, Hm = _quadratic(F, ha)
        step = _newton(c, g, Hm, ha, UV[ar, k], np.isfinite(F).all(axis=1)) - c
        # backtracking along the step: fractions 1, 1/2, 1/4, 1/8 evaluated at once
        trial = np.clip(c[:, None, :] + _FRACTIONS[None, :, None] * step[:, None, :],
                        la[:, None, :], ua[:, None, :]).reshape(-1, 2)
        nt = len(_FRACTIONS)
        ft, pt, trial = obj(np.repeat(rows[a], nt), np.repeat(sid[a], nt), trial[:, 0],
                            trial[:, 1])
        pick = ar * nt + np.argmin(ft.reshape(-1, nt), axis=1)
        fn, pn, new = ft[pick], pt[pick], trial[pick]
        newton_won = fn < best_f[a]
        _keep_best(best_f, best_uv, best_p, a, fn, new, pn)
        evals[a] += 9 + nt
        shrink = np.where(k == 4, 0.25, 0.5)[:, None] * ha
        jump = np.clip(2.0 * np.abs(new - c), 0.125 * ha, ha)
        h[a] = np.clip(np.where(newton_won[:, None], jump, shrink), hmin[a], 0.25 * width[a])
        active[a] &= ~(h[a] <= 2.0 * hmin[a]).all(axis=1)  # converged
    return Refined(best_f, best_uv, best_p, evals)


def _keep_best(best_f, best_uv, best_p, idx, f, uv, p) -> None:
    """Update the best-so-far of starts `idx` with values f, parameters uv, points p."""
    better = f < best_f[idx]
    t = idx[better]
    best_f[t], best_uv[t], best_p[t] = f[better], uv[better], p[better]


def _quadratic(F: np.ndarray, h: np.ndarray):
    """Gradient (S, 2) and Hessian (S, 2, 2) of the quadratic through the 3x3 stencil values
    F (S, 9) (row-major over du in -1, 0, 1 then dv), half-widths h (S, 2)."""
    with np.errstate(invalid="ignore"):
        f = F.reshape(-1, 3, 3)
        hu, hv = h[:, 0], h[:, 1]
        gu = (f[:, 2, 1] - f[:, 0, 1]) / (2 * hu)
        gv = (f[:, 1, 2] - f[:, 1, 0]) / (2 * hv)
        huu = (f[:, 2, 1] - 2 * f[:, 1, 1] + f[:, 0, 1]) / hu**2
        hvv = (f[:, 1, 2] - 2 * f[:, 1, 1] + f[:, 1, 0]) / hv**2
        huv = (f[:, 2, 2] - f[:, 2, 0] - f[:, 0, 2] + f[:, 0, 0]) / (4 * hu * hv)
    g = np.stack([gu, gv], axis=1)
    Hm = np.stack([np.stack([huu, huv], axis=1), np.stack([huv, hvv], axis=1)], axis=1)
    return g, Hm


def _newton(c, g, Hm, h, fallback, finite):
    """Newton point from the stencil centre, at most _REACH half-widths per coordinate; the best
    stencil point where the model is not finite or not convex."""
    with np.errstate(invalid="ignore", over="ignore"):
        det = Hm[:, 0, 0] * Hm[:, 1, 1] - Hm[:, 0, 1] ** 2
        du = -(Hm[:, 1, 1] * g[:, 0] - Hm[:, 0, 1] * g[:, 1])
        dv = -(Hm[:, 0, 0] * g[:, 1] - Hm[:, 0, 1] * g[:, 0])
    ok = finite & (Hm[:, 0, 0] > 0) & (det > 0)
    safe = np.where(ok, det, 1.0)
    d = np.stack([du / safe, dv / safe], axis=1)
    d = np.where(np.isfinite(d), d, 0.0)
    big = np.abs(d) > _REACH * h
    scale = np.min(np.where(big, _REACH * h / np.maximum(np.abs(d), 1e-300), 1.0), axis=1)
    return np.where(ok[:, None], c + d * scale[:, None], fallback)
