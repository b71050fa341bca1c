"""Batched local refinement in (u, v): every start (a CC row and a point on one surface) takes
the same few quadratic-model steps at once. Each step evaluates a 3x3 stencil, fits the
quadratic (central differences), takes the bounded Newton step when the model is convex (the
best stencil point otherwise), and shrinks the stencil as it converges. Steps stay inside the
surface domain; points outside a trim count as inf. The answer is the best point evaluated.

Surface evaluation is the expensive part and the imaginary-size kernels are cheap, so each step
evaluates the surface once per start: exactly, with second derivatives, at the point the step
picks. The stencil, the Newton step and its backtracking run on the second-order Taylor model
of the surface about the start's best point (error O(h^3) for a stencil of width h, so the
model becomes exact as the steps converge); only exact values are ever reported."""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from checker.cutter import BALL_FAMILY
from checker.engine.frames import heights, rotate_rows
from checker.engine.sizes import RowFrame, pair_sizes, point_size, size_args
from checker.geometry.evaluate import SurfaceEval, evaluate_mixed
from checker.part import Part

_ABOVE = 1e-9  # mm above the bottom plane: on it the kernels already count a point as uncut
_ON_FLOOR = 1e-6  # mm: points this close above the bottom plane lie on its contour
_FLOOR_STEPS = 3
_FRACTIONS = np.array([1.0, 0.5, 0.25, 0.125])
_REACH = 4.0  # longest Newton step, stencil half-widths
_PRUNE_AFTER = 2  # iterations before starts far above their row's best are dropped
_PRUNE_REL, _PRUNE_ABS = 0.01, 0.02  # 'far above': more than 1 % + 0.02 mm
_CONVERGED = 1e-5  # a start stops when its stencil is this fraction of the initial one
_OFFS = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=np.float64)
_CENTRE = 4  # index of the stencil centre in _OFFS
_CHUNK = 256  # model queries per parallel task


@dataclass
class Refined:
    """Per start: `size (S,)` mm, `uv (S, 2)`, `point (S, 3)` part frame, `evaluations (S,)`
    (imaginary sizes computed, on the surface or on its Taylor model)."""

    size: np.ndarray
    uv: np.ndarray
    point: np.ndarray
    evaluations: np.ndarray


@nb.njit(cache=True, inline="always")
def _taylor_at(d, uv0, s, u, v, out):
    """Point and first derivatives (out[0..2], part frame) of start s's Taylor model at (u, v)."""
    a = u - uv0[s, 0]
    b = v - uv0[s, 1]
    for m in range(3):
        su = d[s, 1, m] + a * d[s, 3, m] + b * d[s, 4, m]
        sv = d[s, 2, m] + a * d[s, 4, m] + b * d[s, 5, m]
        out[0, m] = d[s, 0, m] + 0.5 * (a * (su + d[s, 1, m]) + b * (sv + d[s, 2, m]))
        out[1, m] = su
        out[2, m] = sv


@nb.njit(cache=True, inline="always")
def _free(g, x, lo, hi):
    """Height gradient component g (up the surface) of a parameter x in [lo, hi]: 0 where the
    step up the height (along +g) would leave the domain, so that points below the floor slide
    along a domain edge instead of stopping at it (projected gradient)."""
    return 0.0 if (x >= hi and g > 0.0) or (x <= lo and g < 0.0) else g


@nb.njit(cache=True)
def _model_range(d, uv0, starts, rows, Q, floor, snap, lo, hi, u, v, pts, f, sz, k0, k1):
    """`_model_sizes` for the queries k0 <= k < k1."""
    e = np.empty((3, 3))
    for k in range(k0, k1):
        s, r = starts[k], rows[k]
        _taylor_at(d, uv0, s, u[k], v[k], e)
        for _ in range(_FLOOR_STEPS if floor.shape[0] else 0):
            z = Q[r, 2, 0] * e[0, 0] + Q[r, 2, 1] * e[0, 1] + Q[r, 2, 2] * e[0, 2]
            if z >= floor[r] and not (snap and z - floor[r] > _ON_FLOOR):
                break
            gu = Q[r, 2, 0] * e[1, 0] + Q[r, 2, 1] * e[1, 1] + Q[r, 2, 2] * e[1, 2]
            gv = Q[r, 2, 0] * e[2, 0] + Q[r, 2, 1] * e[2, 1] + Q[r, 2, 2] * e[2, 2]
            gu = _free(gu, u[k], lo[k, 0], hi[k, 0])
            gv = _free(gv, v[k], lo[k, 1], hi[k, 1])
            g2 = gu * gu + gv * gv
            if g2 <= 1e-24:
                break
            t = (floor[r] - z) / g2
            u[k] = min(max(u[k] + t * gu, lo[k, 0]), hi[k, 0])
            v[k] = min(max(v[k] + t * gv, lo[k, 1]), hi[k, 1])
            _taylor_at(d, uv0, s, u[k], v[k], e)
        for m in range(3):
            pts[k, m] = e[0, m]
        x = Q[r, 0, 0] * e[0, 0] + Q[r, 0, 1] * e[0, 1] + Q[r, 0, 2] * e[0, 2]
        y = Q[r, 1, 0] * e[0, 0] + Q[r, 1, 1] * e[0, 1] + Q[r, 1, 2] * e[0, 2]
        z = Q[r, 2, 0] * e[0, 0] + Q[r, 2, 1] * e[0, 1] + Q[r, 2, 2] * e[0, 2]
        f[k] = point_size(sz, r, x, y, z)


@nb.njit(cache=True, parallel=True)
def _model_sizes(d, uv0, starts, rows, Q, floor, snap, lo, hi, u, v, pts, f, sz):
    """Model points `pts (K, 3)` (part frame) and their sizes `f (K,)` (rules of
    `sizes.point_size`, tool frame of each row through `Q`) of starts `starts (K,)` at (u, v)
    (K,); with `floor` (per row, tool-frame height; empty: no floor) points below it (with
    `snap`: every point) move onto it first by Newton steps on the model's height (u, v updated
    in place, clipped to [lo, hi] (K, 2)). Parallel over chunks of queries."""
    n = u.shape[0]
    for c in nb.prange((n + _CHUNK - 1) // _CHUNK):
        _model_range(d, uv0, starts, rows, Q, floor, snap, lo, hi, u, v, pts, f, sz, c * _CHUNK,
                     min(n, (c + 1) * _CHUNK))


class _Taylor:
    """Second-order Taylor model of the surface of every start about `uv0 (S, 2)`, from an
    order-2 evaluation `ev` there (part frame, mm per parameter unit)."""

    def __init__(self, uv0: np.ndarray, ev: SurfaceEval) -> None:
        self.uv0 = np.ascontiguousarray(uv0, dtype=np.float64).copy()
        self.d = np.stack([ev.points, ev.du, ev.dv, ev.duu, ev.duv, ev.dvv], axis=1)

    def move(self, starts: np.ndarray, uv0: np.ndarray, ev: SurfaceEval) -> None:
        """Re-centre the models of `starts` on `uv0` with their order-2 evaluation `ev`."""
        self.uv0[starts] = uv0
        self.d[starts] = np.stack([ev.points, ev.du, ev.dv, ev.duu, ev.duv, ev.dvv], axis=1)


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
        self.sz = size_args(cutter, frame, np.arange(len(frame.cc)))

    def exact(self, rows, sid, u, v, order: int = 2):
        """(f (K,), points (K, 3) part frame, uv (K, 2), evaluation of that order) on the
        surfaces."""
        u, v = u.copy(), v.copy()
        ev = evaluate_mixed(self.part, sid, u, v, order=order)
        if self.floor is not None:
            self._onto_floor(rows, sid, u, v, ev, order)
        return (*self._sizes(rows, sid, u, v, ev.points), ev)

    def model(self, taylor: _Taylor, starts, rows, sid, u, v, snap: bool = False):
        """(f (K,), points (K, 3), uv (K, 2)) on the Taylor models of `starts (K,)`; `snap`:
        move every point onto the bottom plane (to walk along the contour)."""
        u, v = u.copy(), v.copy()
        pts, f = np.empty((len(u), 3)), np.empty(len(u))
        floor = np.zeros(0) if self.floor is None else self.floor
        d = self.dom[sid]
        _model_sizes(taylor.d, taylor.uv0, starts, rows, self.Q, floor, snap,
                     np.ascontiguousarray(d[:, :, 0]), np.ascontiguousarray(d[:, :, 1]), u, v,
                     pts, f, self.sz)
        return self._trimmed(sid, u, v, f, pts)

    def _sizes(self, rows, sid, u, v, pts):
        """(f (K,), points, uv (K, 2)): sizes of the part-frame points, inf outside trims."""
        f = pair_sizes(self.cutter, self.frame, rows, rotate_rows(self.Q, pts, rows))
        return self._trimmed(sid, u, v, f, pts)

    def _trimmed(self, sid, u, v, f, pts):
        """(f, points, uv (K, 2)) with f = inf at the points outside their surface's trim."""
        for s in self.trimmed:
            sel = np.flatnonzero(sid == s)
            if sel.size:
                out = ~np.asarray(self.part.surfaces[s].trim.contains(u[sel], v[sel]), dtype=bool)
                f[sel[out]] = np.inf
        return f, pts, np.column_stack([u, v])

    def _onto_floor(self, rows, sid, u, v, ev, order: int) -> None:
        """Move points below their row's bottom plane onto it (in place: u, v, ev)."""
        for _ in range(_FLOOR_STEPS):
            z = heights(self.Q, ev.points, rows)
            low = np.flatnonzero(z < self.floor[rows])
            if low.size == 0:
                return
            d = self.dom[sid[low]]
            gu = _free_rows(heights(self.Q, ev.du[low], rows[low]), u[low], d[:, 0])
            gv = _free_rows(heights(self.Q, ev.dv[low], rows[low]), v[low], d[:, 1])
            g2 = gu * gu + gv * gv
            ok = g2 > 1e-24
            low, gu, gv, g2, d = low[ok], gu[ok], gv[ok], g2[ok], d[ok]
            t = (self.floor[rows[low]] - z[low]) / g2
            u[low] = np.clip(u[low] + t * gu, d[:, 0, 0], d[:, 0, 1])
            v[low] = np.clip(v[low] + t * gv, d[:, 1, 0], d[:, 1, 1])
            sub = evaluate_mixed(self.part, sid[low], u[low], v[low], order=order)
            for name in ("points", "du", "dv", "duu", "duv", "dvv")[:3 * order]:
                getattr(ev, name)[low] = getattr(sub, name)


def _free_rows(g: np.ndarray, x: np.ndarray, dom: np.ndarray) -> np.ndarray:
    """`_free` for arrays: g (K,), x (K,), dom (K, 2) the parameter's [lo, hi]."""
    return np.where(((x >= dom[:, 1]) & (g > 0.0)) | ((x <= dom[:, 0]) & (g < 0.0)), 0.0, g)


def refine(part: Part, cutter, frame: RowFrame, Q: np.ndarray, rows: np.ndarray, sid: np.ndarray,
           uv: np.ndarray, step: np.ndarray, iterations: int = 8) -> Refined:
    """Refine S starts: `rows (S,)` CC rows of `frame` (tool frames `Q (N, 3, 3)`, one per row),
    `sid (S,)` surfaces, `uv (S, 2)` start parameters, `step (S, 2)` initial stencil half-widths
    in parameter units."""
    obj = _Objective(part, cutter, frame, Q)
    dom = obj.dom
    lo, hi = dom[sid, :, 0], dom[sid, :, 1]
    width = hi - lo
    hmin = np.maximum(1e-10 * np.maximum(width, 1e-300), _CONVERGED * step)
    cur = np.clip(uv, lo, hi)
    f, pts, cur, ev = obj.exact(rows, sid, cur[:, 0], cur[:, 1])
    best_f, best_uv, best_p = f.copy(), cur.copy(), pts.copy()
    taylor = _Taylor(cur, ev)
    h = np.clip(step, hmin, 0.25 * width)
    evals = np.ones(len(rows), dtype=np.int64)
    active = np.ones(len(rows), dtype=bool)
    nrow = int(rows.max()) + 1 if rows.size else 0
    nt = len(_FRACTIONS)
    for it in range(iterations):
        if it >= _PRUNE_AFTER:  # drop starts clearly above the best of their row
            row_best = np.full(nrow, np.inf)
            np.minimum.at(row_best, rows, best_f)
            active &= ~(best_f > row_best[rows] * (1.0 + _PRUNE_REL) + _PRUNE_ABS)
        a = np.flatnonzero(active)
        if a.size == 0:
            break
        ha, la, ua, ra, sa = h[a], lo[a], hi[a], rows[a], sid[a]
        ar = np.arange(a.size)
        c = np.clip(best_uv[a], la + ha, ua - ha)
        UV = (c[:, None, :] + _OFFS[None] * ha[:, None, :]).reshape(-1, 2)
        F, _, UV = obj.model(taylor, np.repeat(a, 9), np.repeat(ra, 9), np.repeat(sa, 9),
                             UV[:, 0], UV[:, 1])
        F, UV = F.reshape(-1, 9), UV.reshape(-1, 9, 2)
        k = np.where(F[:, _CENTRE] <= F.min(axis=1), _CENTRE, np.argmin(F, axis=1))
        g, Hm = _quadratic(F, ha)
        move = _newton(c, g, Hm, ha, UV[ar, k], np.isfinite(F).all(axis=1)) - c
        # backtracking along the step: fractions 1, 1/2, 1/4, 1/8 evaluated at once
        trial = np.clip(c[:, None, :] + _FRACTIONS[None, :, None] * move[:, None, :],
                        la[:, None, :], ua[:, None, :]).reshape(-1, 2)
        ft, _, trial = obj.model(taylor, np.repeat(a, nt), np.repeat(ra, nt), np.repeat(sa, nt),
                                 trial[:, 0], trial[:, 1])
        pick = ar * nt + np.argmin(ft.reshape(-1, nt), axis=1)
        newton = ft[pick] < F[ar, k]
        cand = np.where(newton[:, None], trial[pick], UV[ar, k])
        along = np.zeros(a.size, dtype=bool)
        if obj.floor is not None:
            along = _along_contour(obj, taylor, a, ra, sa, best_f[a], best_p[a], ha,
                                   np.minimum(ft[pick], F[ar, k]), cand)
            evals[a] += along.astype(np.int64) * (2 + nt)
        fe, pe, ue, eve = obj.exact(ra, sa, cand[:, 0], cand[:, 1])
        evals[a] += 9 + nt + 1
        won = fe < best_f[a]
        t = a[won]
        best_f[t], best_uv[t], best_p[t] = fe[won], ue[won], pe[won]
        taylor.move(t, ue[won], _rows_of(eve, won))
        shrink = np.where(k == _CENTRE, 0.25, 0.5)[:, None] * ha
        # a Newton step sets the stencil to its length, a step along the contour may grow it
        reach = np.where(along, _REACH, 1.0)[:, None] * ha
        jump = np.clip(2.0 * np.abs(ue - c), 0.125 * ha, reach)
        h[a] = np.clip(np.where((won & (newton | along))[:, None], jump, shrink), hmin[a],
                       0.25 * width[a])
        active[a] &= ~(h[a] <= 2.0 * hmin[a]).all(axis=1)  # converged
    return Refined(best_f, best_uv, best_p, evals)


def _along_contour(obj: _Objective, taylor: _Taylor, a: np.ndarray, rows: np.ndarray,
                   sid: np.ndarray, f0: np.ndarray, p0: np.ndarray, h: np.ndarray, fc: np.ndarray,
                   cand: np.ndarray) -> np.ndarray:
    """A 1-D step along the bottom-plane contour for the starts `a` (CC rows `rows`, surfaces
    `sid`) whose best point (value f0, part-frame point p0) lies on it (flat-bottomed cutters):
    on the Taylor model, the values at +-tau mm along the contour (tau from the stencil
    half-widths h), the parabola's vertex and its fractions, every point snapped onto the
    plane. Where one beats the 2-D candidate's model value `fc`, it replaces `cand` (in
    place); returns that mask."""
    on = np.flatnonzero(heights(obj.Q, p0, rows) - obj.floor[rows] <= _ON_FLOOR)
    found = np.zeros(len(a), dtype=bool)
    if on.size == 0:
        return found
    s, r, d = a[on], rows[on], taylor.d[a[on]]
    qz = obj.Q[r, 2]
    gu, gv = np.einsum("ij,ij->i", qz, d[:, 1]), np.einsum("ij,ij->i", qz, d[:, 2])
    mm = np.linalg.norm(-gv[:, None] * d[:, 1] + gu[:, None] * d[:, 2], axis=1)  # mm per unit
    t_uv = np.column_stack([-gv, gu]) / np.maximum(mm, 1e-300)[:, None]  # uv per mm along it
    tau = 0.5 * (h[on, 0] * np.linalg.norm(d[:, 1], axis=1) +
                 h[on, 1] * np.linalg.norm(d[:, 2], axis=1))
    ts = np.column_stack([-tau, tau])
    fm_fp, uv_pm = _on_contour(obj, taylor, s, r, sid[on], ts, t_uv)
    fm, fp = fm_fp[:, 0], fm_fp[:, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        curv = fm - 2.0 * f0[on] + fp
        vertex = np.where(curv > 0, tau * (fm - fp) / (2.0 * curv),
                          np.sign(fm - fp) * _REACH * tau)
    vertex = np.clip(np.nan_to_num(vertex), -_REACH * tau, _REACH * tau)
    ft, uv_t = _on_contour(obj, taylor, s, r, sid[on], vertex[:, None] * _FRACTIONS, t_uv)
    vals = np.concatenate([fm_fp, ft], axis=1)
    uvs = np.concatenate([uv_pm, uv_t], axis=1)
    j = np.argmin(vals, axis=1)
    better = vals[np.arange(on.size), j] < fc[on]
    cand[on[better]] = uvs[np.arange(on.size), j][better]
    found[on[better]] = True
    return found


def _on_contour(obj: _Objective, taylor: _Taylor, s: np.ndarray, rows: np.ndarray,
                sid: np.ndarray, t: np.ndarray, t_uv: np.ndarray):
    """Model values (K, m) and uv (K, m, 2) at t (K, m) mm along the contour tangents
    `t_uv (K, 2)` from the model centres of starts `s (K,)` (rows, surfaces), snapped onto the
    plane."""
    m = t.shape[1]
    d = obj.dom[sid]
    uv = np.clip(taylor.uv0[s, None, :] + t[:, :, None] * t_uv[:, None, :], d[:, None, :, 0],
                 d[:, None, :, 1]).reshape(-1, 2)
    f, _, uv = obj.model(taylor, np.repeat(s, m), np.repeat(rows, m), np.repeat(sid, m),
                         uv[:, 0], uv[:, 1], snap=True)
    return f.reshape(-1, m), uv.reshape(-1, m, 2)


def _rows_of(ev: SurfaceEval, mask: np.ndarray) -> SurfaceEval:
    """The evaluation of the points `mask` selects."""
    return SurfaceEval(ev.points[mask], ev.du[mask], ev.dv[mask], ev.normals[mask],
                       ev.duu[mask], ev.duv[mask], ev.dvv[mask])


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
