"""Batch evaluation of (rational) B-spline surfaces: points, derivatives, unit normals and
principal curvatures at many (u, v) at once, in mm in the part frame.

One numba kernel per call: per point it finds the knot spans, builds the basis functions and
their derivatives (Cox-de Boor, The NURBS Book A2.3), contracts them with the homogeneous poles
and applies the quotient rule for rational surfaces (A4.4). Surfaces are packed into flat
arrays, so points on many surfaces go through one call (`evaluate_mixed`; `points_mixed` for the
points alone); 4,000 points or more run in parallel chunks. No Python runs per point. (u, v)
outside the domain are clipped onto it. Surfaces are treated as immutable once evaluated (their
packed poles are cached on them).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.part import Part, Surface

_CHUNK = 512
_NO_IDS = np.zeros(0, dtype=np.int64)
_PARALLEL_MIN = 4_000  # fewer points: one thread (thread start-up costs more than it saves)
_MAXDEG = 32
_SLOTS = (1, 3, 6, 10)  # derivatives S, Su, Sv, ... up to each order
# int64 constants for compiled callers (indices and counts): numba compiles a kernel once more
# for every Python int constant passed to it (typed as its literal value) and for a parallel
# loop's index (uint64); these and np.int64(index) keep one signature. `eval_range`'s order is
# passed as a constant all the same, one signature per order: its loops then have fixed lengths
ZERO, ONE = np.int64(0), np.int64(1)


@nb.njit(cache=True, forceinline=True)
def _find_span(knots: np.ndarray, p: int, n: int, x: float) -> int:
    """Index s in [p, n-1] with knots[s] <= x < knots[s+1] (last span at the right end)."""
    if x >= knots[n]:
        return n - 1
    if x <= knots[p]:
        return p
    lo, hi = p, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if x < knots[mid]:
            hi = mid
        else:
            lo = mid
    return lo


@nb.njit(cache=True, _nrt=False)
def _basis_ders(knots, p, span, x, nd, ders, ndu, a, left, right):
    """Basis functions N_{span-p..span} and their derivatives up to order nd into ders[k, j]."""
    ndu[0, 0] = 1.0
    for j in range(1, p + 1):
        left[j] = x - knots[span + 1 - j]
        right[j] = knots[span + j] - x
        saved = 0.0
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    for j in range(p + 1):
        ders[0, j] = ndu[j, p]
    for k in range(1, nd + 1):
        for j in range(p + 1):
            ders[k, j] = 0.0
    n = min(nd, p)
    for r in range(p + 1):
        s1, s2 = 0, 1
        a[0, 0] = 1.0
        for k in range(1, n + 1):
            d = 0.0
            rk, pk = r - k, p - k
            if r >= k:
                a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                d = a[s2, 0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                d += a[s2, j] * ndu[rk + j, pk]
            if r <= pk:
                a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                d += a[s2, k] * ndu[r, pk]
            ders[k, r] = d
            s1, s2 = s2, s1
    fac = float(p)
    for k in range(1, n + 1):
        for j in range(p + 1):
            ders[k, j] *= fac
        fac *= p - k


class EvalScratch(NamedTuple):
    """Work arrays of `eval_range` (one set per thread): the basis functions and their
    derivatives in u and v, Cox-de Boor's tables, the contracted homogeneous derivatives."""

    Nu: np.ndarray
    Nv: np.ndarray
    ndu: np.ndarray
    a: np.ndarray
    left: np.ndarray
    right: np.ndarray
    A: np.ndarray
    T: np.ndarray


@nb.njit(cache=True, forceinline=True)
def eval_scratch() -> EvalScratch:
    """A fresh `EvalScratch`."""
    return EvalScratch(np.empty((4, _MAXDEG + 1)), np.empty((4, _MAXDEG + 1)),
                       np.empty((_MAXDEG + 1, _MAXDEG + 1)), np.empty((2, _MAXDEG + 1)),
                       np.empty(_MAXDEG + 1), np.empty(_MAXDEG + 1), np.empty((10, 4)),
                       np.empty((4, 4)))


@nb.njit(cache=True, _nrt=False)
def eval_range(G, sid, u, v, order, out, normals, i0, i1, sc):
    """out[i, m] for m = S, Su, Sv (, Suu, Suv, Svv (, Suuu, Suuv, Suvv, Svvv)) and unit
    normals[i] for i in [i0, i1), point i on packed surface sid[i] (surface 0 when sid is
    empty); see `_Packed`. `sc`: an `EvalScratch` (compiled callers evaluate a few points at a
    time with theirs)."""
    knots_u, ou, knots_v, ov, Hw, op, nus, nvs, degu, degv, signs = G
    Nu, Nv, ndu, a, left, right, A, T = sc
    last = 0
    ku = knots_u[ou[0] : ou[1]]
    kv = knots_v[ov[0] : ov[1]]
    p, q, nu, nv, base = degu[0], degv[0], nus[0], nvs[0], op[0]
    for i in range(i0, i1):
        s = sid[i] if sid.shape[0] > 0 else 0
        if s != last:
            last = s
            ku = knots_u[ou[s] : ou[s + 1]]
            kv = knots_v[ov[s] : ov[s + 1]]
            p, q, nu, nv, base = degu[s], degv[s], nus[s], nvs[s], op[s]
        x = min(max(u[i], ku[p]), ku[nu])
        y = min(max(v[i], kv[q]), kv[nv])
        su = _find_span(ku, p, nu, x)
        sv = _find_span(kv, q, nv, y)
        _basis_ders(ku, p, su, x, order, Nu, ndu, a, left, right)
        _basis_ders(kv, q, sv, y, order, Nv, ndu, a, left, right)
        A[:, :] = 0.0
        for ii in range(p + 1):
            T[:, :] = 0.0
            row = base + (su - p + ii) * nv + sv - q
            for jj in range(q + 1):
                for l in range(order + 1):
                    b = Nv[l, jj]
                    for m in range(4):
                        T[l, m] += b * Hw[row + jj, m]
            for m in range(4):
                A[0, m] += Nu[0, ii] * T[0, m]
                if order >= 1:
                    A[1, m] += Nu[1, ii] * T[0, m]
                    A[2, m] += Nu[0, ii] * T[1, m]
                if order >= 2:
                    A[3, m] += Nu[2, ii] * T[0, m]
                    A[4, m] += Nu[1, ii] * T[1, m]
                    A[5, m] += Nu[0, ii] * T[2, m]
                if order >= 3:
                    A[6, m] += Nu[3, ii] * T[0, m]
                    A[7, m] += Nu[2, ii] * T[1, m]
                    A[8, m] += Nu[1, ii] * T[2, m]
                    A[9, m] += Nu[0, ii] * T[3, m]
        w = A[0, 3]
        if order == 0:
            for m in range(3):
                out[i, 0, m] = A[0, m] / w
            continue
        for m in range(3):
            S = A[0, m] / w
            Su = (A[1, m] - A[1, 3] * S) / w
            Sv = (A[2, m] - A[2, 3] * S) / w
            out[i, 0, m] = S
            out[i, 1, m] = Su
            out[i, 2, m] = Sv
            if order >= 2:
                out[i, 3, m] = (A[3, m] - 2.0 * A[1, 3] * Su - A[3, 3] * S) / w
                out[i, 4, m] = (A[4, m] - A[1, 3] * Sv - A[2, 3] * Su - A[4, 3] * S) / w
                out[i, 5, m] = (A[5, m] - 2.0 * A[2, 3] * Sv - A[5, 3] * S) / w
            if order >= 3:  # Leibniz on A = w S (The NURBS Book eq. 4.20)
                Suu, Suv, Svv = out[i, 3, m], out[i, 4, m], out[i, 5, m]
                out[i, 6, m] = (A[6, m] - 3.0 * A[1, 3] * Suu - 3.0 * A[3, 3] * Su
                                - A[6, 3] * S) / w
                out[i, 7, m] = (A[7, m] - 2.0 * A[1, 3] * Suv - A[3, 3] * Sv - A[2, 3] * Suu
                                - 2.0 * A[4, 3] * Su - A[7, 3] * S) / w
                out[i, 8, m] = (A[8, m] - 2.0 * A[2, 3] * Suv - A[5, 3] * Su - A[1, 3] * Svv
                                - 2.0 * A[4, 3] * Sv - A[8, 3] * S) / w
                out[i, 9, m] = (A[9, m] - 3.0 * A[2, 3] * Svv - 3.0 * A[5, 3] * Sv
                                - A[9, 3] * S) / w
        nx = out[i, 1, 1] * out[i, 2, 2] - out[i, 1, 2] * out[i, 2, 1]
        ny = out[i, 1, 2] * out[i, 2, 0] - out[i, 1, 0] * out[i, 2, 2]
        nz = out[i, 1, 0] * out[i, 2, 1] - out[i, 1, 1] * out[i, 2, 0]
        nn = np.sqrt(nx * nx + ny * ny + nz * nz)
        scale = 0.0
        for m in range(3):
            scale += out[i, 1, m] * out[i, 1, m] + out[i, 2, m] * out[i, 2, m]
        # |Su x Sv| negligible against |Su|^2 + |Sv|^2: a pole, left as 0 for the caller
        nn = signs[s] / nn if nn > 1e-12 * scale else 0.0
        normals[i, 0] = nx * nn
        normals[i, 1] = ny * nn
        normals[i, 2] = nz * nn


@nb.njit(cache=True, parallel=True)
def _eval_parallel(G, sid, u, v, order, out, normals):
    """eval_range over all points in parallel chunks."""
    n = u.shape[0]
    for c in nb.prange((n + _CHUNK - 1) // _CHUNK):
        i0 = np.int64(c) * _CHUNK
        eval_range(G, sid, u, v, order, out, normals, i0, min(n, i0 + _CHUNK), eval_scratch())


@dataclass
class SurfaceEval:
    """Evaluation at N parameter pairs: `points`, first derivatives `du`, `dv` (mm per unit
    parameter), unit `normals` (out of the material), with order >= 2 `duu`, `duv`, `dvv` and
    with order 3 `duuu`, `duuv`, `duvv`, `dvvv`; all (N, 3) in the part frame. Normals are
    exact limits at degenerate points (poles)."""

    points: np.ndarray
    du: np.ndarray
    dv: np.ndarray
    normals: np.ndarray
    duu: np.ndarray | None = None
    duv: np.ndarray | None = None
    dvv: np.ndarray | None = None
    duuu: np.ndarray | None = None
    duuv: np.ndarray | None = None
    duvv: np.ndarray | None = None
    dvvv: np.ndarray | None = None


@dataclass
class Curvatures:
    """Principal curvatures `k1 >= k2` (1/mm; positive where the surface bends away from its
    normal, i.e. convex as seen by the tool) and unit principal directions `d1`, `d2` (N, 3)."""

    k1: np.ndarray
    k2: np.ndarray
    d1: np.ndarray
    d2: np.ndarray


class _Packed(NamedTuple):
    """Surfaces packed into flat arrays for the kernel: knots of surface s are
    knots_u[ou[s]:ou[s+1]], its weighted poles Hw[op[s] + i * nvs[s] + j] (x w, y w, z w, w)."""

    knots_u: np.ndarray
    ou: np.ndarray
    knots_v: np.ndarray
    ov: np.ndarray
    Hw: np.ndarray
    op: np.ndarray
    nus: np.ndarray
    nvs: np.ndarray
    degu: np.ndarray
    degv: np.ndarray
    signs: np.ndarray


def _pack(surfaces: list[Surface]) -> _Packed:
    for s in surfaces:
        if max(s.degree_u, s.degree_v) > _MAXDEG:
            raise ValueError(f"surface {s.id}: degree above {_MAXDEG} is not supported")

    def offsets(sizes) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)

    ints = lambda xs: np.array(xs, dtype=np.int64)  # noqa: E731
    return _Packed(
        np.concatenate([s.knots_u for s in surfaces]),
        offsets([s.knots_u.size for s in surfaces]),
        np.concatenate([s.knots_v for s in surfaces]),
        offsets([s.knots_v.size for s in surfaces]),
        np.ascontiguousarray(np.concatenate([s.homogeneous.reshape(-1, 4) for s in surfaces])),
        offsets([s.ctrlpts.shape[0] * s.ctrlpts.shape[1] for s in surfaces]),
        ints([s.ctrlpts.shape[0] for s in surfaces]),
        ints([s.ctrlpts.shape[1] for s in surfaces]),
        ints([s.degree_u for s in surfaces]),
        ints([s.degree_v for s in surfaces]),
        np.zeros(len(surfaces)),
    )


def _packed(owner: Surface | Part, surfaces: list[Surface]) -> _Packed:
    """The packed geometry of `surfaces`, cached on `owner` (surfaces are treated as immutable
    once evaluated); the normal signs follow the surfaces' current `flip`."""
    key = tuple(id(s) for s in surfaces)
    hit = owner.__dict__.get("_packed")
    if hit is None or hit[0] != key:
        hit = (key, _pack(surfaces))
        owner.__dict__["_packed"] = hit
    packed = hit[1]
    return packed._replace(signs=np.array([-1.0 if s.flip else 1.0 for s in surfaces]))


def _run(G: _Packed, sid: np.ndarray, u: np.ndarray, v: np.ndarray, order: int):
    n = u.shape[0]
    out = np.empty((n, _SLOTS[order], 3))
    normals = np.empty((n, 3))
    if n >= _PARALLEL_MIN:
        _eval_parallel(G, sid, u, v, order, out, normals)
    else:
        eval_range(G, sid, u, v, order, out, normals, 0, n, eval_scratch())
    return out, normals


def _derivatives(order: int) -> int:
    """`order` checked: the derivatives asked of `evaluate` and `evaluate_mixed`."""
    if order not in (1, 2, 3):
        raise ValueError(f"order must be 1, 2 or 3, got {order}")
    return order


def _raw_eval(surface: Surface, u: np.ndarray, v: np.ndarray, order: int):
    return _run(_packed(surface, [surface]), _NO_IDS, u, v, order)


def _params(u, v) -> tuple[np.ndarray, np.ndarray]:
    u = np.ascontiguousarray(np.atleast_1d(u), dtype=np.float64).ravel()
    v = np.ascontiguousarray(np.atleast_1d(v), dtype=np.float64).ravel()
    if u.shape != v.shape:
        raise ValueError(f"u and v differ in length: {u.shape} vs {v.shape}")
    return u, v


def _fix_degenerate(surface: Surface, u: np.ndarray, v: np.ndarray, normals: np.ndarray) -> None:
    """Replace zero normals (collapsed edges, poles) by the limit from just inside the domain."""
    bad = ~np.isfinite(normals).all(axis=1) | (np.abs(normals).sum(axis=1) == 0.0)
    if not bad.any():
        return
    (u0, u1), (v0, v1) = surface.domain
    uc, vc = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
    for t in (1e-9, 1e-7, 1e-5):
        idx = np.flatnonzero(bad)
        if idx.size == 0:
            return
        us = np.clip(u[idx], u0, u1) + t * (uc - u[idx])
        vs = np.clip(v[idx], v0, v1) + t * (vc - v[idx])
        _, nrm = _raw_eval(surface, us, vs, 1)
        ok = np.abs(nrm).sum(axis=1) > 0.0
        normals[idx[ok]] = nrm[ok]
        bad[idx[ok]] = False


def _surface_eval(out: np.ndarray, normals: np.ndarray) -> SurfaceEval:
    ev = SurfaceEval(out[:, 0], out[:, 1], out[:, 2], normals)
    if out.shape[1] > 3:
        ev.duu, ev.duv, ev.dvv = out[:, 3], out[:, 4], out[:, 5]
    if out.shape[1] > 6:
        ev.duuu, ev.duuv, ev.duvv, ev.dvvv = out[:, 6], out[:, 7], out[:, 8], out[:, 9]
    return ev


def evaluate(surface: Surface, u, v, order: int = 1) -> SurfaceEval:
    """Evaluate `surface` at parameter arrays `u`, `v` (N,); derivatives of order 1, 2 or 3."""
    u, v = _params(u, v)
    out, normals = _raw_eval(surface, u, v, _derivatives(order))
    _fix_degenerate(surface, u, v, normals)
    return _surface_eval(out, normals)


def _mixed(part: Part, surface_ids, u, v, order: int):
    """(ids, u, v, kernel output, normals) for K points on the surfaces `surface_ids (K,)`."""
    u, v = _params(u, v)
    ids = np.ascontiguousarray(surface_ids, dtype=np.int64).ravel()
    if ids.shape != u.shape:
        raise ValueError(f"surface_ids has {ids.size} entries for {u.size} parameters")
    if ids.size and (ids.min() < 0 or ids.max() >= len(part.surfaces)):
        raise ValueError(f"surface ids must lie in [0, {len(part.surfaces)})")
    return (ids, u, v, *_run(_packed(part, part.surfaces), ids, u, v, order))


def points_mixed(part: Part, surface_ids, u, v) -> np.ndarray:
    """(K, 3) mm: the points alone of `evaluate_mixed`, the same values (no derivatives, so
    cheaper)."""
    return _mixed(part, surface_ids, u, v, 0)[3][:, 0]


def evaluate_mixed(part: Part, surface_ids, u, v, order: int = 1) -> SurfaceEval:
    """Evaluate K points that lie on different surfaces of `part` (`surface_ids (K,)` int,
    `u`, `v` (K,)) in one kernel call over the part's packed surfaces."""
    ids, u, v, out, normals = _mixed(part, surface_ids, u, v, _derivatives(order))
    bad = np.flatnonzero(np.abs(normals).sum(axis=1) == 0.0)
    for sid in np.unique(ids[bad]):  # poles only: a handful of points, if any
        sel = bad[ids[bad] == sid]
        normals[sel] = evaluate(part.surfaces[int(sid)], u[sel], v[sel]).normals
    return _surface_eval(out, normals)


def curvatures_of(ev: SurfaceEval) -> Curvatures:
    """Principal curvatures and directions from an order-2 evaluation."""
    if ev.duu is None:
        raise ValueError("principal curvatures need an order=2 evaluation")
    n = ev.normals
    E = np.einsum("ij,ij->i", ev.du, ev.du)
    F = np.einsum("ij,ij->i", ev.du, ev.dv)
    G = np.einsum("ij,ij->i", ev.dv, ev.dv)
    L = -np.einsum("ij,ij->i", ev.duu, n)
    M = -np.einsum("ij,ij->i", ev.duv, n)
    N = -np.einsum("ij,ij->i", ev.dvv, n)
    det = E * G - F * F
    H = (E * N - 2.0 * F * M + G * L) / (2.0 * det)
    K = (L * N - M * M) / det
    root = np.sqrt(np.maximum(H * H - K, 0.0))
    k1, k2 = H + root, H - root
    d1 = _direction(ev, E, F, G, L, M, N, k1)
    d2 = np.cross(n, d1)
    return Curvatures(k1, k2, d1, d2)


def _direction(ev, E, F, G, L, M, N, k) -> np.ndarray:
    """Unit 3-D principal direction for curvature k: kernel of (II - k I) mapped by (du, dv)."""
    a1, b1 = -(M - k * F), L - k * E
    a2, b2 = N - k * G, -(M - k * F)
    use1 = a1 * a1 + b1 * b1 >= a2 * a2 + b2 * b2
    a, b = np.where(use1, a1, a2), np.where(use1, b1, b2)
    d = a[:, None] * ev.du + b[:, None] * ev.dv
    umbilic = np.linalg.norm(d, axis=1) <= 1e-12 * np.linalg.norm(ev.du, axis=1)
    d[umbilic] = ev.du[umbilic]
    return d / np.linalg.norm(d, axis=1)[:, None]


def principal_curvatures(surface: Surface, u, v) -> Curvatures:
    """Principal curvatures (1/mm) and directions of `surface` at (u, v) (N,)."""
    return curvatures_of(evaluate(surface, u, v, order=2))


def packed_part(part: Part) -> _Packed:
    """The part's surfaces packed for `eval_range` (cached on the part)."""
    return _packed(part, part.surfaces)
