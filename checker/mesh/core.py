"""The core K of a tool's piece in its profile plane (tool frame: tip at the origin, axis +z; r
the radial distance, h the height, mm): the pieces as the kernels take them, a piece's core
clipped for one pose, its sides, its erosion K (-) tB and the signed distance to it.

K is the solid of revolution of a convex half-profile polygon with an edge (or a vertex) on the
axis (`checker.mesh.tool`). K = {a_i r + b_i h <= c_i} over the sides not on the axis (outer unit
normals (a_i, b_i), a_i >= 0), and a_i r(x) + b_i h(x) is 1-Lipschitz in x and grows at rate
exactly 1 along (a_i w, b_i) (w the radial direction), so a point's depth in K is
min_i (c_i - a_i r - b_i h) and the erosion K (-) tB = {a_i r + b_i h <= c_i - t}: the profile
clipped by the moved sides (exact for any convex profile). A degenerate core (a segment on the
axis: the ball) has no interior. (docs/MATH.md §8)"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.mesh.tool import drop_repeats

PROFILE_ROWS = 24  # profile vertices after clipping, at most (tool.MAXV + clips)


class Tools(NamedTuple):
    """The pieces of one or more tools as the kernels take them (tool frame, mm): half-profiles
    `profile (P, MAXV, 2)` (r, h) counter-clockwise, rows [:count[p]], `count (P,)`; the ball
    radius each core is grown by `rho (P,)`; `kind (P,)` (`tool.BODY`, `SHANK`, `HOLDER`); tool
    k's pieces are first[k] .. first[k + 1] - 1 (`first (K + 1,)`)."""

    profile: np.ndarray
    count: np.ndarray
    rho: np.ndarray
    kind: np.ndarray
    first: np.ndarray


class Core(NamedTuple):
    """A piece's core clipped for one pose (tool frame, mm): `profile (PROFILE_ROWS, 2)` its
    half-profile (r, h) counter-clockwise, rows [:count] (count 0: nothing left); its `sides`
    not on the axis, a r + b h <= c, outer unit normals `normal (PROFILE_ROWS, 2)` (a, b),
    a >= 0, offsets `offset (PROFILE_ROWS,)` (c); `solid` whether it has an interior; `rho` the
    radius the piece grows it by; `rmax` its radius, `hlo`..`hhi` its heights."""

    profile: np.ndarray
    count: int
    normal: np.ndarray
    offset: np.ndarray
    sides: int
    solid: bool
    rho: float
    rmax: float
    hlo: float
    hhi: float


@nb.njit(cache=True)
def core_buffers():
    """Empty profile, normals and offsets for `piece_core` (one set per thread)."""
    return (np.empty((PROFILE_ROWS, 2)), np.empty((PROFILE_ROWS, 2)), np.empty(PROFILE_ROWS))


@nb.njit(cache=True)
def clip(P, m, nr, nh, c, out):
    """Sutherland-Hodgman: the convex polygon P[:m] cut to {nr r + nh h <= c} into `out`;
    returns the vertex count (consecutive duplicates removed)."""
    k = 0
    if m == 0:
        return 0
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        d0 = nr * P[i, 0] + nh * P[i, 1] - c
        d1 = nr * P[j, 0] + nh * P[j, 1] - c
        if d0 <= 0.0:
            out[k, 0], out[k, 1] = P[i, 0], P[i, 1]
            k += 1
        if m > 1 and (d0 <= 0.0) != (d1 <= 0.0):
            s = d0 / (d0 - d1)
            out[k, 0] = P[i, 0] + s * (P[j, 0] - P[i, 0])
            out[k, 1] = P[i, 1] + s * (P[j, 1] - P[i, 1])
            k += 1
    return drop_repeats(out, k, 1e-13)


@nb.njit(cache=True)
def _sides(P, m, normal, offset):
    """The sides of P[:m] that are not on the axis: outer unit normals (a, b), a >= 0, into
    `normal` and offsets (a r + b h <= c) into `offset`; returns (count, solid) where solid means
    P has an interior."""
    nc = 0
    area = 0.0
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        r0, h0, r1, h1 = P[i, 0], P[i, 1], P[j, 0], P[j, 1]
        area += r0 * h1 - r1 * h0
        if r0 <= 0.0 and r1 <= 0.0:
            continue
        dr, dh = r1 - r0, h1 - h0
        L = math.sqrt(dr * dr + dh * dh)
        if L <= 1e-14:
            continue
        a, b = dh / L, -dr / L
        normal[nc, 0], normal[nc, 1] = a, b
        offset[nc] = a * r0 + b * h0
        nc += 1
    return nc, (nc > 0 and area > 0.0)


@nb.njit(cache=True)
def piece_core(tools, p, h1, profile, normal, offset):
    """The `Core` of piece p of `tools` for one pose, in the buffers `profile`, `normal`,
    `offset` (`core_buffers`): an unbounded piece cut first at height h1 (above the mesh, with
    room for what is measured), then at h1 plus its radius there (room for depths)."""
    m0 = tools.count[p]
    P = tools.profile[p]
    rho = tools.rho[p]
    mc = clip(P, m0, 0.0, 1.0, h1, profile)
    rr = 0.0
    for k in range(mc):
        rr = max(rr, profile[k, 0])
    mc = clip(P, m0, 0.0, 1.0, h1 + rr, profile)
    if mc == 0:
        return Core(profile, 0, normal, offset, 0, False, rho, 0.0, 0.0, 0.0)
    nc, solid = _sides(profile, mc, normal, offset)
    rmax, hlo, hhi = 0.0, np.inf, -np.inf
    for k in range(mc):
        rmax = max(rmax, profile[k, 0])
        hlo = min(hlo, profile[k, 1])
        hhi = max(hhi, profile[k, 1])
    return Core(profile, mc, normal, offset, nc, solid, rho, rmax, hlo, hhi)


@nb.njit(cache=True)
def eroded(core, t, buf_a, buf_b):
    """The profile of K (-) tB (mm): the core's profile clipped by every side moved in by t.
    Returns (polygon, count); the polygon is one of the two buffers (PROFILE_ROWS, 2)."""
    src = core.profile
    cnt = core.count
    use_a = True
    for i in range(core.sides):
        dst = buf_a if use_a else buf_b
        cnt = clip(src, cnt, core.normal[i, 0], core.normal[i, 1], core.offset[i] - t, dst)
        src = dst
        use_a = not use_a
        if cnt == 0:
            break
    return src, cnt


@nb.njit(cache=True, forceinline=True)
def _nearest_on_profile(P, m, r, h):
    """The point (qr, qh) of the closed polygon P[:m] nearest (r, h), and its squared distance."""
    best = np.inf
    qr, qh = P[0, 0], P[0, 1]
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        ar, ah = P[i, 0], P[i, 1]
        er, eh = P[j, 0] - ar, P[j, 1] - ah
        L2 = er * er + eh * eh
        s = 0.0
        if L2 > 0.0:
            s = ((r - ar) * er + (h - ah) * eh) / L2
            s = min(1.0, max(0.0, s))
        pr, ph = ar + s * er, ah + s * eh
        d2 = (r - pr) ** 2 + (h - ph) ** 2
        if d2 < best:
            best, qr, qh = d2, pr, ph
    return best, qr, qh


@nb.njit(cache=True)
def signed_distance(core, P, m, t, r, h):
    """Signed distance (mm) from (r, h) (r >= 0) to the profile of K (-) tB, P[:m] that profile
    (`eroded`; t = 0: the core's own): negative inside (minus the depth
    min_i (c_i - t - a_i r - b_i h)), else the distance to the polygon; and the nearest profile
    point (the point itself inside)."""
    if core.solid:
        g = np.inf
        for i in range(core.sides):
            g = min(g, core.offset[i] - t - (core.normal[i, 0] * r + core.normal[i, 1] * h))
        if g >= 0.0:
            return -g, r, h
    if m == 0:
        return np.inf, r, h
    best, qr, qh = _nearest_on_profile(P, m, r, h)
    return math.sqrt(best), qr, qh


@nb.njit(cache=True)
def signed_distance_gradient(core, r, h):
    """Signed distance (mm) from (r, h) to the core's profile and its gradient in (r, h) (a
    subgradient where it has a kink)."""
    if core.solid:
        g = np.inf
        ia = 0
        for i in range(core.sides):
            gi = core.offset[i] - (core.normal[i, 0] * r + core.normal[i, 1] * h)
            if gi < g:
                g, ia = gi, i
        if g >= 0.0:
            return -g, core.normal[ia, 0], core.normal[ia, 1]
    best, qr, qh = _nearest_on_profile(core.profile, core.count, r, h)
    d = math.sqrt(best)
    if d > 0.0:
        return d, (r - qr) / d, (h - qh) / d
    return 0.0, 0.0, 0.0


@nb.njit(cache=True)
def lift(x, y, qr, qh):
    """The point (tool frame, mm) at radius qr, height qh in the meridian half-plane of (x, y)."""
    rr = math.sqrt(x * x + y * y)
    if rr > 0.0:
        return qr * x / rr, qr * y / rr, qh
    return qr, 0.0, qh
