"""Refinement starts on rings around each CC point, on each surface it lies on, and the size's
limit at the CC point itself, in one compiled parallel kernel over the contacts.

Near the CC point the size is the curvature limit plus a term linear in the distance
(third-order contact), so a minimum can lie at any distance below the samples' resolution,
where no Newton walk from a sample reaches it (a cone's tip); a ring within a factor of it
does. The rings' points are even in the tangent plane (not in (u, v)): a tangent direction t
is the (u, v) step `G^-1 [S_u S_v]^T t` (G the first fundamental form). The first ring
(_FIRST_RING directions) probes the curvature limit; the wider rings take the direction of the
closed-form limit (limits.py), else the first ring's best (interpolated between its samples by a
parabola), its opposite and 8 even ones: the narrow valleys near the CC point that the samples
do not resolve leave it along that direction (a sector a few degrees wide at 0.01 mm). The best
point of each ring is a start. Along the best direction the size is s0 + b rho + O(rho^2);
where b > 0 the infimum s0 is at the CC point, which no point reaches: where the closed form
does not apply it is extrapolated from rho and rho/2 (Richardson).
(docs/MATH.md §6.2, §6.3)"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from checker.engine.grid.rotations import rotated
from checker.engine.refine.objective import Objective, point_batch
from checker.engine.refine.starts import Contacts, Starts
from checker.engine.sizes import RowFrame, point_size
from checker.geometry.evaluate import ONE, ZERO, eval_range
from checker.part import Part

# directions on the first ring around a CC point, and on each wider one (the best direction, its
# opposite, 8 even ones); int64, not Python ints: a count passed to a kernel would compile it
# again for its literal value (evaluate.ZERO)
_FIRST_RING = np.int64(16)
_WIDER_RING = np.int64(10)
_RING_RATIO = 3.0  # the wider rings' radii grow by at most this
_CHUNK = 64  # contacts per parallel task


class CCLimits(NamedTuple):
    """The size's limits at CC points themselves: `rows (K,)`, `size (K,)` mm, on `surface
    (K,)` at `uv (K, 2)`."""

    rows: np.ndarray
    size: np.ndarray
    surface: np.ndarray
    uv: np.ndarray


class _Tangents(NamedTuple):
    """A contact's tangent plane: orthonormal tangents t1 (along S_u), t2 (part frame), S_u and
    S_v, the first fundamental form (E, F, G) and 1 / (EG - F^2) (0 where singular)."""

    t1: np.ndarray
    t2: np.ndarray
    su: np.ndarray
    sv: np.ndarray
    e: float
    f: float
    g: float
    inv: float


def ring_radii(ring: float, spacing: float) -> list[float]:
    """The rings probed around a CC point (mm): `ring` (its own curvature), then radii growing by
    at most _RING_RATIO up to half the test-point spacing, and 1.5 spacings."""
    top = max(0.5 * spacing, ring)
    count = int(np.ceil(np.log(top / ring) / np.log(_RING_RATIO))) + 1
    return [*np.geomspace(ring, top, max(count, 2)).tolist(), 1.5 * spacing]


def ring_evaluations(radii: list[float]) -> int:
    """Sizes evaluated on the rings of `radii` around one CC point on one surface
    (`ring_starts`): _FIRST_RING on the first, _WIDER_RING on each wider one."""
    return int(_FIRST_RING + _WIDER_RING * (len(radii) - 1))


@nb.njit(cache=True, _nrt=False)
def _tangents(G, sd, u, v, w, tan) -> _Tangents:
    """The tangent plane of surface sd at (u, v) (module docstring), evaluated through the
    `PointBatch` w; its vectors are the rows t1, t2, S_u, S_v of `tan (4, 3)` (views, not
    counted: its callers count no references either)."""
    w.sid[0], w.u[0], w.v[0] = sd, u, v
    eval_range(G, w.sid, w.u, w.v, 1, w.ev, w.normals, ZERO, ONE, w.sc)
    t1, t2, su, sv = tan[0], tan[1], tan[2], tan[3]
    for m in range(3):
        su[m], sv[m] = w.ev[0, 1, m], w.ev[0, 2, m]
    nx = su[1] * sv[2] - su[2] * sv[1]  # the parametrisation's normal: the rings' sense
    ny = su[2] * sv[0] - su[0] * sv[2]
    nz = su[0] * sv[1] - su[1] * sv[0]
    nn = max(np.sqrt(nx * nx + ny * ny + nz * nz), 1e-300)
    nx, ny, nz = nx / nn, ny / nn, nz / nn
    a = su[0] * nx + su[1] * ny + su[2] * nz
    t1[0], t1[1], t1[2] = su[0] - a * nx, su[1] - a * ny, su[2] - a * nz
    m = max(np.sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]), 1e-300)
    t1[0], t1[1], t1[2] = t1[0] / m, t1[1] / m, t1[2] / m
    t2[0] = ny * t1[2] - nz * t1[1]
    t2[1] = nz * t1[0] - nx * t1[2]
    t2[2] = nx * t1[1] - ny * t1[0]
    e = su[0] * su[0] + su[1] * su[1] + su[2] * su[2]
    f = su[0] * sv[0] + su[1] * sv[1] + su[2] * sv[2]
    g = sv[0] * sv[0] + sv[1] * sv[1] + sv[2] * sv[2]
    det = e * g - f * f
    return _Tangents(t1, t2, su, sv, e, f, g, 1.0 / det if det > 0.0 else 0.0)


@nb.njit(cache=True, _nrt=False, forceinline=True)
def _uv_step(tg: _Tangents, angle, rho):
    """The (u, v) step of a tangent of length `rho` mm at `angle` rad from t1 towards t2."""
    c, s = np.cos(angle), np.sin(angle)
    bu = bv = 0.0
    for m in range(3):
        t = c * tg.t1[m] + s * tg.t2[m]
        bu += t * tg.su[m]
        bv += t * tg.sv[m]
    return rho * ((tg.g * bu - tg.f * bv) * tg.inv), rho * ((tg.e * bv - tg.f * bu) * tg.inv)


@nb.njit(cache=True, _nrt=False)
def _sizes_at(G, Q, sz, r, n, w):
    """Sizes w.size[:n] of row r at the surface points (w.sid, w.u, w.v)[:n] (order-0)."""
    eval_range(G, w.sid, w.u, w.v, 0, w.ev, w.normals, ZERO, n, w.sc)
    for j in range(n):
        x, y, z = rotated(Q, r, w.ev[j], 0)
        w.size[j] = point_size(sz, r, x, y, z)


@nb.njit(cache=True, _nrt=False)
def _on_ring(G, Q, sz, dom, r, sd, u, v, tg, angles, m, rho, w):
    """The sizes at the m points of the ring of radius rho around (u, v) at `angles[:m]`
    (clipped to the domain; their (u, v) in w.u, w.v); the index of the smallest."""
    for j in range(m):
        du, dv = _uv_step(tg, angles[j], rho)
        w.sid[j] = sd
        w.u[j] = min(max(u + du, dom[sd, 0, 0]), dom[sd, 0, 1])
        w.v[j] = min(max(v + dv, dom[sd, 1, 0]), dom[sd, 1, 1])
    _sizes_at(G, Q, sz, r, m, w)
    k = 0
    for j in range(1, m):
        if w.size[j] < w.size[k]:
            k = j
    return k


@nb.njit(cache=True, _nrt=False, forceinline=True)
def _best_angle(f, m):
    """The angle (rad) of the smallest of the m values f at even angles, between the samples
    by a parabola through the best and its two neighbours (the sample where they are not
    finite)."""
    k = 0
    for j in range(1, m):
        if f[j] < f[k]:
            k = j
    a, b, c = f[(k - 1) % m], f[k], f[(k + 1) % m]
    den = a - 2.0 * b + c
    shift = 0.5 * (a - c) / den if den != 0.0 else np.nan
    shift = min(max(shift, -0.5), 0.5) if np.isfinite(shift) else 0.0
    return k * 2.0 * np.pi / m + shift * (2.0 * np.pi / m)


@nb.njit(cache=True, _nrt=False)
def _limit_at_cc(G, Q, sz, dom, r, sd, u, v, tg, angle, rho, w):
    """The size's limit at the CC point along `angle`, 2 s(rho/2) - s(rho) (never below 0 nor
    above s(rho/2)); the opposite direction where that one leaves the surface's domain (a CC
    point on its boundary; the curvature is the same); nan where a size is not finite."""
    du, dv = _uv_step(tg, angle, rho)
    if (u + du < dom[sd, 0, 0] or u + du > dom[sd, 0, 1] or v + dv < dom[sd, 1, 0]
            or v + dv > dom[sd, 1, 1]):
        du, dv = -du, -dv
    for j in range(2):
        w.sid[j] = sd
        w.u[j] = min(max(u + (0.5 if j == 0 else 1.0) * du, dom[sd, 0, 0]), dom[sd, 0, 1])
        w.v[j] = min(max(v + (0.5 if j == 0 else 1.0) * dv, dom[sd, 1, 0]), dom[sd, 1, 1])
    _sizes_at(G, Q, sz, r, np.int64(2), w)
    near, far = w.size[0], w.size[1]
    if not (np.isfinite(near) and np.isfinite(far)):
        return np.nan
    return max(min(2.0 * near - far, near), 0.0)


@nb.njit(cache=True, _nrt=False)
def _contacts(G, Q, sz, dom, rows, sid, uv, toward, settled, radii, k0, k1, start, half, limit,
              w, tan, angles):
    """Rings of `radii` (mm) around contacts k0..k1: ring j's best point into start[k, j] (nan
    where no size is finite) with its stencil half-widths half[k, j] (parameter units: the
    first ring's radius, then half the ring's); the limit at the CC point into limit[k] where
    the closed form is not `settled[k]` (nan elsewhere); the wider rings along the closed
    form's direction `toward[k]` (part frame), else the first ring's best. `w`, `tan`,
    `angles`: scratch (`_scratch`)."""
    for k in range(k0, k1):
        r, sd, u, v = rows[k], sid[k], uv[k, 0], uv[k, 1]
        tg = _tangents(G, sd, u, v, w, tan)
        per_u = 1.0 / max(np.sqrt(tg.su[0] ** 2 + tg.su[1] ** 2 + tg.su[2] ** 2), 1e-12)
        per_v = 1.0 / max(np.sqrt(tg.sv[0] ** 2 + tg.sv[1] ** 2 + tg.sv[2] ** 2), 1e-12)
        m = _FIRST_RING
        for j in range(m):
            angles[j] = j * 2.0 * np.pi / m
        for j in range(radii.shape[0]):
            rho = radii[j]
            b = _on_ring(G, Q, sz, dom, r, sd, u, v, tg, angles, m, rho, w)
            ok = np.isfinite(w.size[b])
            start[k, j, 0] = w.u[b] if ok else np.nan
            start[k, j, 1] = w.v[b] if ok else np.nan
            scale = rho * (1.0 if j == 0 else 0.5)
            half[k, j, 0], half[k, j, 1] = scale * per_u, scale * per_v
            if j > 0:
                continue
            known = np.isfinite(toward[k, 0] + toward[k, 1] + toward[k, 2])
            if known:  # the closed form's direction
                best = np.arctan2(toward[k, 0] * tg.t2[0] + toward[k, 1] * tg.t2[1]
                                  + toward[k, 2] * tg.t2[2],
                                  toward[k, 0] * tg.t1[0] + toward[k, 1] * tg.t1[1]
                                  + toward[k, 2] * tg.t1[2])
            else:
                best = _best_angle(w.size, m)
            limit[k] = np.nan
            if not settled[k]:
                limit[k] = _limit_at_cc(G, Q, sz, dom, r, sd, u, v, tg, best, rho, w)
            m = _WIDER_RING
            angles[0], angles[1] = best, best + np.pi
            for i in range(8):
                angles[2 + i] = i * np.pi / 4


@nb.njit(cache=True, forceinline=True)
def _scratch():
    """The work arrays of `_contacts`: a `PointBatch` for the largest ring, the tangent plane's
    vectors and the rings' angles."""
    most = max(_FIRST_RING, _WIDER_RING)
    return point_batch(most, 3), np.empty((4, 3)), np.empty(most)


@nb.njit(cache=True, parallel=True)
def _all_contacts(G, Q, sz, dom, rows, sid, uv, toward, settled, radii, start, half, limit):
    """`_contacts` in parallel chunks of _CHUNK contacts."""
    n = rows.shape[0]
    for c in nb.prange((n + _CHUNK - 1) // _CHUNK):
        w, tan, angles = _scratch()
        k0 = np.int64(c) * _CHUNK
        _contacts(G, Q, sz, dom, rows, sid, uv, toward, settled, radii, k0, min(n, k0 + _CHUNK),
                  start, half, limit, w, tan, angles)


def ring_starts(part: Part, cutter, frame: RowFrame, Q: np.ndarray, contacts: Contacts,
                radii: list[float], toward: np.ndarray,
                settled: np.ndarray) -> tuple[Starts, CCLimits]:
    """Around each CC point, on each surface it lies on (`contacts`), the best points of the
    rings of `radii` (mm) as refinement starts (ring by ring), and the limits at the CC points
    where the closed form (limits.py) is not `settled (K,)`; the wider rings follow its
    direction `toward (K, 3)` (part frame, nan where none) (module docstring)."""
    rows = np.ascontiguousarray(contacts.rows, dtype=np.int64)
    sid = np.ascontiguousarray(contacts.surface, dtype=np.int64)
    uv = np.ascontiguousarray(contacts.uv, dtype=np.float64)
    k, j = len(rows), len(radii)
    start, half, limit = np.empty((k, j, 2)), np.empty((k, j, 2)), np.empty(k)
    if k:
        obj = Objective(part, cutter, frame, Q)
        _all_contacts(obj.G, obj.Q, obj.sz, obj.dom, rows, sid, uv,
                      np.ascontiguousarray(toward, dtype=np.float64),
                      np.ascontiguousarray(settled, dtype=np.bool_),
                      np.asarray(radii, dtype=np.float64), start, half, limit)
    ok = np.isfinite(start[..., 0])
    starts = Starts.join([Starts(rows[ok[:, i]], sid[ok[:, i]], start[ok[:, i], i],
                                 half[ok[:, i], i]) for i in range(j)])
    at = np.isfinite(limit)
    return starts, CCLimits(rows[at], limit[at], sid[at], uv[at])
