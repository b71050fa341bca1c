"""The material-removal kernel: tool pieces swept along straight translations cut the Z-dexel
stock, ray by ray, in program order (docs/MATH.md §14). Part frame, mm.

A piece is a convex solid of revolution: the core polygon (counter-clockwise (r, h) vertices,
r >= 0, h above the tip along the axis) grown by a ball of radius rho (checker/mesh/tool.py).
An item translates the tool from tip `a` to tip `b` at a constant unit axis.

- Vertical axis (+z): exact per ray. At radial distance d the piece spans h in
  [h_low(d), h_high(d)]; over the item the ray lies in the swept piece for z in
  [min_t z(t) + h_low(d(t)), max_t z(t) + h_high(d(t))] over the t with d(t) <= r_max
  (closed-form t-range). The ends are closed forms for a level move, a cylinder (flat end,
  shank, holder) and a capsule (ball end); a bull-nose is closed-form under its flat part and
  searched under its torus; other profiles by Brent's method on the convex (concave) function,
  the end values taken exactly.
- Any other axis: the translation sampled at spacing <= step; per pose the ray's interval in
  the piece, from the convex distance f(s) = dist2D((r, h), core) - rho along the ray
  (golden-section minimum, then bisected roots).

Pieces are applied in the order given (the driver passes holder, shank, then body), each
against the ray's material as the earlier ones left it: material two pieces overlap in one
item is charged to the non-cutting piece, so a holder or shank entry is never hidden behind
the body's own cut of the same item.

The grid is cut in square tiles run in parallel; each tile runs the items touching it in
program order, so no two threads touch one ray and each tile-item pair writes its own row
of statistics (`ST_*` columns), reduced per move after."""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

TILE = 64                       # rays per tile side
BLOCK = 8                       # rays per side of a block skipped whole when out of reach
VERTICAL = 1e-9                 # an axis whose x and y are within this of 0 (and z > 0) is +z
GENERIC, CYLINDER, CAPSULE, BULL = 0, 1, 2, 3
ENGAGE_COLS = 3
# statistics columns of one tile-item row
ST_LEN = 0          # 3: material length removed per kind, summed over rays (mm)
ST_THICK = 3        # 3: the largest length removed on one ray per kind (mm)
ST_WHERE = 6        # 9: per kind the (x, y, z-middle) of that ray's removed stretch
ST_Q = 15           # 4: body engaged rays' extent: q min, q max, q2 min, q2 max (mm)
ST_RAYS = 19        # the rays the body is engaged on (removes more than `engage` from)
NST = 20
_INVPHI = 0.6180339887498949
_TOL = 1e-6         # mm: the searches' tolerance
_F32 = 2.0 ** -23   # float32's relative spacing: a stored end is within this of the value cut


@nb.njit(cache=True)
def prof_span(prof, n, rho, d):
    """(h_low, h_high) of the core prof[:n] grown by rho on the line r = d (d >= 0); (inf,
    -inf) when the line misses it. Each edge grown by rho is a capsule: its extent on the
    line comes from its two end discs and its two long sides."""
    lo = np.inf
    hi = -np.inf
    for i in range(n):
        ri = prof[i, 0]
        hi_ = prof[i, 1]
        e = abs(d - ri)
        if e <= rho:
            w = math.sqrt(max(rho * rho - e * e, 0.0))
            lo = min(lo, hi_ - w)
            hi = max(hi, hi_ + w)
        if n == 1:
            break
        j = i + 1 if i + 1 < n else 0
        er = prof[j, 0] - ri
        eh = prof[j, 1] - hi_
        ln = math.sqrt(er * er + eh * eh)
        if ln <= 0.0 or abs(er) <= 1e-15:
            continue
        nr = eh / ln
        nh = -er / ln
        for sgn in (-1.0, 1.0):
            sr = ri + sgn * rho * nr
            sh = hi_ + sgn * rho * nh
            t = (d - sr) / er
            if 0.0 <= t <= 1.0:
                z = sh + t * eh
                lo = min(lo, z)
                hi = max(hi, z)
    return lo, hi


@nb.njit(cache=True)
def prof_dist(prof, n, r, h):
    """2-D distance from (r, h) to the convex polygon prof[:n] (0 inside)."""
    inside = n >= 3
    best = np.inf
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        pr, ph = prof[i, 0], prof[i, 1]
        er, eh = prof[j, 0] - pr, prof[j, 1] - ph
        wr, wh = r - pr, h - ph
        if er * wh - eh * wr < 0.0:
            inside = False
        l2 = er * er + eh * eh
        t = 0.0
        if l2 > 0.0:
            t = min(max((wr * er + wh * eh) / l2, 0.0), 1.0)
        dr, dh = wr - t * er, wh - t * eh
        best = min(best, math.sqrt(dr * dr + dh * dh))
        if n == 1:
            break
    return 0.0 if inside else best


@nb.njit(cache=True)
def _swept_end(t, sign, ax, ay, az, vx, vy, vz, px, py, prof, n, rho, rmax, bull, g0, g1):
    """sign +1: z(t) + h_low(d(t)); sign -1: -(z(t) + h_high(d(t))). A bull-nose (`bull`: the
    core [0, R] x [g0, g1], R = rmax - rho) in closed form, any other profile by prof_span."""
    dx = ax + t * vx - px
    dy = ay + t * vy - py
    d = min(math.sqrt(dx * dx + dy * dy), rmax)
    if bull:
        e = d - (rmax - rho)
        w = rho
        if e > 0.0:
            w = math.sqrt(max(rho * rho - e * e, 0.0))
        if sign > 0.0:
            return az + t * vz + g0 - w
        return -(az + t * vz + g1 + w)
    lo, hi = prof_span(prof, n, rho, d)
    if sign > 0.0:
        return az + t * vz + lo
    return -(az + t * vz + hi)


@nb.njit(cache=True)
def _min_swept(t0, t1, sign, stop, ax, ay, az, vx, vy, vz, px, py, prof, n, rho, rmax, bull,
               g0, g1):
    """Minimum over [t0, t1] of the convex _swept_end (sign as there), by Brent's method
    (parabolic steps, golden-section ones where they fail) to 1e-7 mm of travel, the two end
    values taken exactly; stops early once a value <= stop is found (the answer is then only
    known to be <= stop)."""
    best = min(_swept_end(t0, sign, ax, ay, az, vx, vy, vz, px, py, prof, n, rho, rmax, bull, g0,
                           g1),
               _swept_end(t1, sign, ax, ay, az, vx, vy, vz, px, py, prof, n, rho, rmax, bull, g0,
                           g1))
    if best <= stop or t1 - t0 <= 0.0:
        return best
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)
    tol = _TOL * 0.1 / max(speed, 1e-12)
    cg = 1.0 - _INVPHI
    a, b = t0, t1
    x = w = v = a + cg * (b - a)
    fx = fw = fv = _swept_end(x, sign, ax, ay, az, vx, vy, vz, px, py, prof, n, rho, rmax, bull, g0,
                           g1)
    d = 0.0
    e = 0.0
    for _ in range(100):
        best = min(best, fx)
        if best <= stop:
            break
        m = 0.5 * (a + b)
        if abs(x - m) <= 2.0 * tol - 0.5 * (b - a):
            break
        golden = True
        if abs(e) > tol:
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            if abs(p) < abs(0.5 * q * e) and p > q * (a - x) and p < q * (b - x):
                e = d
                d = p / q
                golden = False
                if (x + d) - a < 2.0 * tol or b - (x + d) < 2.0 * tol:
                    d = tol if m >= x else -tol
        if golden:
            e = (a - x) if x >= m else (b - x)
            d = cg * e
        u = x + d if abs(d) >= tol else x + (tol if d >= 0.0 else -tol)
        fu = _swept_end(u, sign, ax, ay, az, vx, vy, vz, px, py, prof, n, rho, rmax, bull, g0,
                           g1)
        if fu <= fx:
            if u >= x:
                a = x
            else:
                b = x
            v, fv = w, fw
            w, fw = x, fx
            x, fx = u, fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, fv = w, fw
                w, fw = u, fu
            elif fu <= fv or v in (x, w):
                v, fv = u, fu
    return min(best, fx)


@nb.njit(cache=True)
def capsule_line(cx, cy, cz, vx, vy, vz, rho, px, py):
    """(zlo, zhi) of the vertical line (px, py) inside the capsule of radius rho about the
    segment c + t v, t in [0, 1]; (inf, -inf) when it misses."""
    lo = np.inf
    hi = -np.inf
    for k in range(2):
        ex = cx + k * vx - px
        ey = cy + k * vy - py
        w = rho * rho - ex * ex - ey * ey
        if w >= 0.0:
            s = math.sqrt(w)
            z = cz + k * vz
            lo = min(lo, z - s)
            hi = max(hi, z + s)
    l2 = vx * vx + vy * vy + vz * vz
    hz = vx * vx + vy * vy
    if l2 > 0.0 and hz > 1e-18 * l2:
        wx, wy = px - cx, py - cy
        k = wx * vx + wy * vy
        qa = hz / l2                      # u^2 coefficient, u = z - cz
        qb = -k * vz / l2                 # half the u coefficient
        qc = wx * wx + wy * wy - k * k / l2 - rho * rho
        disc = qb * qb - qa * qc
        if disc >= 0.0:
            s = math.sqrt(disc)
            for sg in (-1.0, 1.0):
                u = (-qb + sg * s) / qa
                t = (k + u * vz) / l2
                if 0.0 <= t <= 1.0:
                    lo = min(lo, cz + u)
                    hi = max(hi, cz + u)
    return lo, hi


@nb.njit(cache=True, forceinline=True)
def vertical_interval(q, ptypes, profs, nprofs, rhos, rmaxs, geos, ax, ay, az, vx, vy, vz,
                      px, py, mbot, mtop):
    """(c0, c1) of the ray (px, py) inside the piece swept vertically from tip a by v, clipped
    to what matters against material in [mbot, mtop]; c0 >= c1 when the sweep misses the
    material. Piece q of the arrays; `geo` its (h_bottom, h_top) for a cylinder, its sphere
    centres' (h0, h1) for a capsule. (Scalars are read here rather than array views passed:
    a view per ray costs reference counting in the hot loop.)"""
    ptype = ptypes[q]
    rho = rhos[q]
    rmax = rmaxs[q]
    g0 = geos[q, 0]
    g1 = geos[q, 1]
    wx, wy = ax - px, ay - py
    qa = vx * vx + vy * vy
    if vz == 0.0:                               # level: the nearest point of the travel
        ts = 0.0
        if qa > 0.0:
            ts = min(max(-(wx * vx + wy * vy) / qa, 0.0), 1.0)
        dx, dy = wx + ts * vx, wy + ts * vy
        d2 = dx * dx + dy * dy
        if d2 > rmax * rmax:
            return 0.0, -1.0
        if ptype == CYLINDER:
            return max(az + g0, mbot), min(az + g1, mtop)
        if ptype == CAPSULE:
            w = math.sqrt(max(rho * rho - d2, 0.0))
            return max(az + g0 - w, mbot), min(az + g1 + w, mtop)
        hl, hh = prof_span(profs[q], nprofs[q], rho, math.sqrt(d2))
        return max(az + hl, mbot), min(az + hh, mtop)
    t0, t1 = 0.0, 1.0
    ts = 0.0
    if qa < 1e-24:
        if wx * wx + wy * wy > rmax * rmax:
            return 0.0, -1.0
    else:
        qb = wx * vx + wy * vy
        qc = wx * wx + wy * wy - rmax * rmax
        disc = qb * qb - qa * qc
        if disc < 0.0:
            return 0.0, -1.0
        s = math.sqrt(disc)
        t0 = max((-qb - s) / qa, 0.0)
        t1 = min((-qb + s) / qa, 1.0)
        if t0 > t1:
            return 0.0, -1.0
        ts = min(max(-qb / qa, t0), t1)
    dx, dy = wx + ts * vx, wy + ts * vy
    dmin = min(math.sqrt(dx * dx + dy * dy), rmax)
    z0, z1 = az + t0 * vz, az + t1 * vz
    zlo, zhi = min(z0, z1), max(z0, z1)
    if ptype == CYLINDER:
        return max(zlo + g0, mbot), min(zhi + g1, mtop)
    if ptype == CAPSULE:
        if zlo + g0 - math.sqrt(max(rho * rho - dmin * dmin, 0.0)) >= mtop:
            return 0.0, -1.0
        c0, _ = capsule_line(ax, ay, az + g0, vx, vy, vz, rho, px, py)
        if zlo + g1 >= mtop:                # the top sphere's centre is above: c1 too
            return max(c0, mbot), mtop
        _, c1 = capsule_line(ax, ay, az + g1, vx, vy, vz, rho, px, py)
        return max(c0, mbot), min(c1, mtop)
    prof = profs[q]
    n = nprofs[q]
    bull = ptype == BULL
    if bull:
        hl = _swept_end(ts, 1.0, ax, ay, 0.0, vx, vy, 0.0, px, py, prof, n, rho, rmax, True,
                        g0, g1)
        hh = -_swept_end(ts, -1.0, ax, ay, 0.0, vx, vy, 0.0, px, py, prof, n, rho, rmax, True,
                         g0, g1)
    else:
        hl, hh = prof_span(prof, n, rho, dmin)
    if zlo + hl >= mtop or zhi + hh <= mbot:
        return 0.0, -1.0
    # the search's range: all of [t0, t1]; for a bull-nose only where the ray is under the
    # torus on the side the move goes down (up, for the top) to, the flat part being linear
    lo0, lo1, hi0, hi1 = t0, t1, t0, t1
    c0 = np.inf
    c1 = -np.inf
    if bull:
        rf = rmax - rho
        qc = wx * wx + wy * wy - rf * rf
        if qa < 1e-24:
            if qc <= 0.0:                       # under the flat part the whole time
                lo1, hi1 = lo0, hi0
                c0 = zlo + g0 - rho
                c1 = zhi + g1 + rho
        else:
            qb = wx * vx + wy * vy
            disc = qb * qb - qa * qc
            if disc >= 0.0:
                sq = math.sqrt(disc)
                f0 = max((-qb - sq) / qa, t0)
                f1 = min((-qb + sq) / qa, t1)
                if f0 <= f1:
                    za, zb = az + f0 * vz, az + f1 * vz
                    c0 = min(za, zb) + g0 - rho
                    c1 = max(za, zb) + g1 + rho
                    if vz < 0.0:
                        lo0, hi1 = f1, f0
                    else:
                        lo1, hi0 = f0, f1
    if c0 > mbot:
        c0 = min(c0, _min_swept(lo0, lo1, 1.0, mbot, ax, ay, az, vx, vy, vz, px, py, prof, n,
                                rho, rmax, bull, g0, g1))
    zs = az + ts * vz
    c1 = max(c1, zs + hh)
    if c1 < mtop:
        c1 = max(c1, -_min_swept(hi0, hi1, -1.0, -mtop, ax, ay, az, vx, vy, vz, px, py, prof,
                                 n, rho, rmax, bull, g0, g1))
    return max(c0, mbot), min(c1, mtop)


@nb.njit(cache=True)
def _f_ray(s, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho):
    wx, wy, wz = px - tx, py - ty, s - tz
    hh = wx * ux + wy * uy + wz * uz
    rx, ry, rz = wx - hh * ux, wy - hh * uy, wz - hh * uz
    r = math.sqrt(rx * rx + ry * ry + rz * rz)
    return prof_dist(prof, n, r, hh) - rho


@nb.njit(cache=True, forceinline=True)
def posed_range(tx, ty, tz, ux, uy, uz, px, py, hmin, hmax, rmax):
    """(s0, s1): the z of the vertical ray (px, py) within the slab hmin <= h <= hmax along
    the axis (tip t, unit axis u) and within rmax of the axis line; s0 > s1 when none."""
    wx, wy = px - tx, py - ty
    k = wx * ux + wy * uy
    s0, s1 = -np.inf, np.inf
    if abs(uz) > 1e-12:
        a0, a1 = (hmin - k) / uz, (hmax - k) / uz
        s0, s1 = min(a0, a1), max(a0, a1)
    elif k < hmin or k > hmax:
        return 1.0, 0.0
    qa = 1.0 - uz * uz
    qb = -k * uz
    qc = wx * wx + wy * wy - k * k - rmax * rmax
    if qa > 1e-12:
        disc = qb * qb - qa * qc
        if disc < 0.0:
            return 1.0, 0.0
        sq = math.sqrt(disc)
        s0 = max(s0, (-qb - sq) / qa)
        s1 = min(s1, (-qb + sq) / qa)
    elif qc > 0.0:
        return 1.0, 0.0
    return tz + s0, tz + s1


@nb.njit(cache=True)
def posed_interval(prof, n, rho, tx, ty, tz, ux, uy, uz, px, py, s0, s1):
    """(c0, c1) of the vertical ray (px, py), within [s0, s1], inside the piece at tip t, unit
    axis u; c0 >= c1 when it misses. f(s) = dist2D - rho is convex along the ray: a golden
    search finds a point with f <= 0 (or none), then both roots are bisected to 1e-6 mm."""
    fa = _f_ray(s0, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
    fb = _f_ray(s1, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
    sin_ = np.nan
    if fa <= 0.0:
        sin_ = s0
    elif fb <= 0.0:
        sin_ = s1
    else:
        a, b = s0, s1
        c = b - _INVPHI * (b - a)
        e = a + _INVPHI * (b - a)
        fc = _f_ray(c, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
        fe = _f_ray(e, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
        for _ in range(100):
            if fc <= 0.0:
                sin_ = c
                break
            if fe <= 0.0:
                sin_ = e
                break
            if b - a <= _TOL:
                break
            # f > 0 at both probes: the minimum (f is convex, 1-Lipschitz) cannot be <= 0
            # farther than f from a probe
            if fc < fe:
                b = e
                e = c
                fe = fc
                c = b - _INVPHI * (b - a)
                fc = _f_ray(c, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
            else:
                a = c
                c = e
                fc = fe
                e = a + _INVPHI * (b - a)
                fe = _f_ray(e, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
            if min(fc, fe) > b - a:
                break
    if math.isnan(sin_):
        return 0.0, -1.0
    c0 = s0
    if fa > 0.0:
        c0 = _boundary(s0, sin_, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
    c1 = s1
    if fb > 0.0:
        c1 = _boundary(s1, sin_, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho)
    return c0, c1


@nb.njit(cache=True)
def _boundary(outside, inside, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho):
    """The z where the vertical ray (px, py) leaves the piece between `outside` (f > 0) and
    `inside` (f <= 0), either below or above it, bisected to `_TOL` mm: the end on the outside,
    so that the interval returned covers the piece."""
    while abs(inside - outside) > _TOL:
        m = 0.5 * (outside + inside)
        if _f_ray(m, tx, ty, tz, ux, uy, uz, px, py, prof, n, rho) <= 0.0:
            inside = m
        else:
            outside = m
    return outside


@nb.njit(cache=True, forceinline=True)
def subtract(lo, hi, count, j, i, c0, c1, out, nlo, nhi):
    """Remove [c0, c1] from ray (j, i). Returns the length removed (mm) and writes the lowest
    and highest removed z to out[0], out[1]; -1.0 when the cut would need more intervals than
    the ray's capacity (the ray is then left as it was). `nlo, nhi` scratch (>= 2 capacity)."""
    c = count[j, i]
    cap = lo.shape[2]
    f0, f1 = np.float32(c0), np.float32(c1)
    if c == 1:                                  # one interval: the common case, in place
        l, u = lo[j, i, 0], hi[j, i, 0]
        if u <= f0 or l >= f1:
            return 0.0
        a = max(float(l), c0)
        b = min(float(u), c1)
        out[0] = a
        out[1] = b
        if l < f0 and u > f1:
            if cap < 2:
                return -1.0
            lo[j, i, 1] = f1
            hi[j, i, 1] = u
            hi[j, i, 0] = f0
            count[j, i] = 2
        elif l < f0:
            hi[j, i, 0] = f0
        elif u > f1:
            lo[j, i, 0] = f1
        else:
            count[j, i] = 0
        return b - a
    m = 0
    removed = 0.0
    zr0 = np.inf
    zr1 = -np.inf
    for k in range(c):
        l, u = lo[j, i, k], hi[j, i, k]
        if u <= f0 or l >= f1:
            nlo[m], nhi[m] = l, u
            m += 1
            continue
        a = max(float(l), c0)
        b = min(float(u), c1)
        removed += b - a
        zr0 = min(zr0, a)
        zr1 = max(zr1, b)
        if l < f0:
            nlo[m], nhi[m] = l, f0
            m += 1
        if u > f1:
            nlo[m], nhi[m] = f1, u
            m += 1
    if removed <= 0.0 and m == c:
        return 0.0
    if m > cap:
        return -1.0
    for k in range(m):
        lo[j, i, k] = nlo[k]
        hi[j, i, k] = nhi[k]
    count[j, i] = m
    out[0] = zr0
    out[1] = zr1
    return removed


@nb.njit(cache=True)
def row_span(ax, ay, vx, vy, r, y):
    """(xmin, xmax) of the line at y inside the 2-D capsule of radius r about the segment from
    (ax, ay) by (vx, vy); xmin > xmax when it misses."""
    xl = np.inf
    xr = -np.inf
    for k in range(2):
        dy = y - (ay + k * vy)
        if abs(dy) <= r:
            w = math.sqrt(r * r - dy * dy)
            cx = ax + k * vx
            xl = min(xl, cx - w)
            xr = max(xr, cx + w)
    ln = math.sqrt(vx * vx + vy * vy)
    if ln > 0.0 and abs(vy) > 1e-15:
        nx, ny = -vy / ln * r, vx / ln * r
        for sg in (-1.0, 1.0):
            t = (y - ay - sg * ny) / vy
            if 0.0 <= t <= 1.0:
                x = ax + sg * nx + t * vx
                xl = min(xl, x)
                xr = max(xr, x)
    return xl - 1e-9, xr + 1e-9


@nb.njit(cache=True, forceinline=True)
def _record(st, e, kind, length, zr0, zr1, px, py):
    st[e, ST_LEN + kind] += length
    if length > st[e, ST_THICK + kind]:
        st[e, ST_THICK + kind] = length
        st[e, ST_WHERE + 3 * kind] = px
        st[e, ST_WHERE + 3 * kind + 1] = py
        st[e, ST_WHERE + 3 * kind + 2] = 0.5 * (zr0 + zr1)


@nb.njit(cache=True, forceinline=True)
def _engaged(st, e, px, py, nxq, nyq, plunge):
    if plunge:
        q, q2 = px, py
    else:
        q, q2 = px * nxq + py * nyq, 0.0
    st[e, ST_Q] = min(st[e, ST_Q], q)
    st[e, ST_Q + 1] = max(st[e, ST_Q + 1], q)
    st[e, ST_Q + 2] = min(st[e, ST_Q + 2], q2)
    st[e, ST_Q + 3] = max(st[e, ST_Q + 3], q2)
    st[e, ST_RAYS] += 1.0


@nb.njit(cache=True)
def piece_box(prof, n, rho, ux, uy, uz, out):
    """Write the axis-aligned box of the piece about its tip (tip at 0, unit axis u) into
    out[0:6] = (xmin, xmax, ymin, ymax, zmin, zmax): each core vertex is a circle of radius r
    about h u, its extent along coordinate k is r sqrt(1 - u_k^2); grown by rho."""
    u = (ux, uy, uz)
    for k in range(3):
        ek = math.sqrt(max(1.0 - u[k] * u[k], 0.0))
        lo = np.inf
        hi = -np.inf
        for v in range(n):
            c = prof[v, 1] * u[k]
            w = prof[v, 0] * ek
            lo = min(lo, c - w)
            hi = max(hi, c + w)
        out[2 * k] = lo - rho
        out[2 * k + 1] = hi + rho


@nb.njit(cache=True)
def item_windows(prof, nprof, rho, a, b, axis, x0, y0, h, nx, ny):
    """Per item the rays its pieces can reach, (S, 4) int64 i0, i1, j0, j1 (inclusive; i0 > i1
    when none), and its lowest reach in z (S,)."""
    S = a.shape[0]
    P = prof.shape[0]
    win = np.empty((S, 4), np.int64)
    zlow = np.empty(S)
    box = np.empty(6)
    for s in range(S):
        xl, xh, yl, yh, zl = np.inf, -np.inf, np.inf, -np.inf, np.inf
        for p in range(P):
            piece_box(prof[p], nprof[p], rho[p], axis[s, 0], axis[s, 1], axis[s, 2], box)
            xl = min(xl, min(a[s, 0], b[s, 0]) + box[0])
            xh = max(xh, max(a[s, 0], b[s, 0]) + box[1])
            yl = min(yl, min(a[s, 1], b[s, 1]) + box[2])
            yh = max(yh, max(a[s, 1], b[s, 1]) + box[3])
            zl = min(zl, min(a[s, 2], b[s, 2]) + box[4])
        win[s, 0] = max(math.ceil((xl - x0) / h - 0.5), 0)
        win[s, 1] = min(math.floor((xh - x0) / h - 0.5), nx - 1)
        win[s, 2] = max(math.ceil((yl - y0) / h - 0.5), 0)
        win[s, 3] = min(math.floor((yh - y0) / h - 0.5), ny - 1)
        zlow[s] = zl
        if win[s, 0] > win[s, 1] or win[s, 2] > win[s, 3]:
            win[s, 0], win[s, 1] = 1, 0
    return win, zlow


@nb.njit(cache=True)
def bin_items(win, ntx, nty):
    """The tile-item pairs, tiles in row-major order and items in program order within each:
    (start (ntiles + 1,), item (E,))."""
    S = win.shape[0]
    nt = ntx * nty
    cnt = np.zeros(nt + 1, np.int64)
    for s in range(S):
        if win[s, 0] > win[s, 1]:
            continue
        for tj in range(win[s, 2] // TILE, win[s, 3] // TILE + 1):
            for ti in range(win[s, 0] // TILE, win[s, 1] // TILE + 1):
                cnt[tj * ntx + ti + 1] += 1
    for t in range(nt):
        cnt[t + 1] += cnt[t]
    fill = cnt[:-1].copy()
    item = np.empty(cnt[nt], np.int64)
    for s in range(S):
        if win[s, 0] > win[s, 1]:
            continue
        for tj in range(win[s, 2] // TILE, win[s, 3] // TILE + 1):
            for ti in range(win[s, 0] // TILE, win[s, 1] // TILE + 1):
                t = tj * ntx + ti
                item[fill[t]] = s
                fill[t] += 1
    return cnt, item


@nb.njit(cache=True)
def _low_at(prof, nprof, rho, ptype, rmax, geo, d):
    """The lowest h of any piece at radial distance d (inf when none reaches d)."""
    best = np.inf
    for p in range(prof.shape[0]):
        if d > rmax[p]:
            continue
        if ptype[p] == CYLINDER:
            v = geo[p, 0]
        elif ptype[p] == CAPSULE:
            v = geo[p, 0] - math.sqrt(max(rho[p] * rho[p] - d * d, 0.0))
        else:
            v, _ = prof_span(prof[p], nprof[p], rho[p], d)
        best = min(best, v)
    return best


@nb.njit(cache=True)
def _block_top(lo, hi, count, i0, i1, j0, j1):
    z = -np.inf
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            c = count[j, i]
            if c > 0:
                z = max(z, hi[j, i, c - 1])
    return z


@nb.njit(cache=True)
def _run_item(lo, hi, count, x0, y0, h, prof, nprof, rho, kind, ptype, rmax, geo, a, b, u,
              step, engage, zlow, i0, i1, j0, j1, st, e, btop, bi0, bj0, sc):
    """Cut rays [i0, i1] x [j0, j1] by one item; statistics to row e. Blocks of BLOCK x BLOCK
    rays whose highest material `btop` (block (bj0, bi0) at btop[0, 0]) lies below the
    item's lowest reach over them are skipped. Returns refused cuts."""
    P = prof.shape[0]
    ny, nx = count.shape
    ax, ay, az = a[0], a[1], a[2]
    vx, vy, vz = b[0] - ax, b[1] - ay, b[2] - az
    vertical = u[2] > 0.0 and abs(u[0]) <= VERTICAL and abs(u[1]) <= VERTICAL
    hv = math.sqrt(vx * vx + vy * vy)
    plunge = hv <= 1e-9
    nxq, nyq = 0.0, 0.0
    if not plunge:
        nxq, nyq = -vy / hv, vx / hv
    length3 = math.sqrt(vx * vx + vy * vy + vz * vz)
    nsamp = 1
    if not vertical:
        nsamp = max(int(math.ceil(length3 / step)) + 1, 2) if length3 > 0.0 else 1
    boxes = sc.boxes
    for p in range(P):
        piece_box(prof[p], nprof[p], rho[p], u[0], u[1], u[2], boxes[p])
    out, nlo, nhi = sc.out, sc.nlo, sc.nhi
    rlen, rz0, rz1 = sc.rlen, sc.rz0, sc.rz1
    rmx = 0.0
    for p in range(P):
        rmx = max(rmx, rmax[p])
    zmin = min(az, az + vz)
    half = (BLOCK - 1) * h / math.sqrt(2.0)
    refused = 0
    dirty = True
    for bj in range(j0 // BLOCK, j1 // BLOCK + 1):
        for bi in range(i0 // BLOCK, i1 // BLOCK + 1):
            top = btop[bj - bj0, bi - bi0]
            if top == -np.inf:
                continue
            if vertical:
                cx = x0 + (bi * BLOCK + 0.5 * BLOCK) * h
                cy = y0 + (bj * BLOCK + 0.5 * BLOCK) * h
                wx, wy = ax - cx, ay - cy
                qa = vx * vx + vy * vy
                ts = 0.0
                if qa > 0.0:
                    ts = min(max(-(wx * vx + wy * vy) / qa, 0.0), 1.0)
                dseg = math.sqrt((wx + ts * vx) ** 2 + (wy + ts * vy) ** 2)
                lb = zmin + _low_at(prof, nprof, rho, ptype, rmax, geo, max(dseg - half, 0.0))
            else:
                lb = zlow
            if lb >= top - _F32 * max(abs(top), 1.0):    # top is a rounded float32
                continue
            touched = False
            ja, jb = max(j0, bj * BLOCK), min(j1, bj * BLOCK + BLOCK - 1)
            ka, kb = max(i0, bi * BLOCK), min(i1, bi * BLOCK + BLOCK - 1)
            for j in range(ja, jb + 1):
                py = y0 + (j + 0.5) * h
                ia, ib = ka, kb
                if vertical:
                    xl, xr = row_span(ax, ay, vx, vy, rmx, py)
                    ia = max(ka, int(math.ceil((xl - x0) / h - 0.5)))
                    ib = min(kb, int(math.floor((xr - x0) / h - 0.5)))
                for i in range(ia, ib + 1):
                    if count[j, i] == 0:
                        continue
                    px = x0 + (i + 0.5) * h
                    if dirty:
                        rlen[:] = 0.0
                        rz0[:] = np.inf
                        rz1[:] = -np.inf
                        dirty = False
                    for k in range(nsamp):
                        f = k / (nsamp - 1) if nsamp > 1 else 0.0
                        tx, ty, tz = ax + f * vx, ay + f * vy, az + f * vz
                        for p in range(P):
                            c = count[j, i]
                            if c == 0:
                                break
                            mbot = float(lo[j, i, 0])
                            mtop = float(hi[j, i, c - 1])
                            if vertical:
                                c0, c1 = vertical_interval(p, ptype, prof, nprof, rho, rmax,
                                                           geo, ax, ay, az, vx, vy, vz, px, py,
                                                           mbot, mtop)
                            else:
                                bx = boxes[p]
                                if (px < tx + bx[0] or px > tx + bx[1] or py < ty + bx[2]
                                        or py > ty + bx[3]):
                                    continue
                                r0, r1 = posed_range(tx, ty, tz, u[0], u[1], u[2], px, py,
                                                     geo[p, 0] - rho[p], geo[p, 1] + rho[p],
                                                     rmax[p])
                                s0 = max(r0, mbot)
                                s1 = min(r1, mtop)
                                if s0 >= s1:
                                    continue
                                if ptype[p] == CYLINDER:        # the slab and cylinder: exact
                                    c0, c1 = s0, s1
                                elif ptype[p] == CAPSULE:
                                    g0, g1 = geo[p, 0], geo[p, 1]
                                    c0, c1 = capsule_line(tx + g0 * u[0], ty + g0 * u[1],
                                                          tz + g0 * u[2], (g1 - g0) * u[0],
                                                          (g1 - g0) * u[1], (g1 - g0) * u[2],
                                                          rho[p], px, py)
                                    c0, c1 = max(c0, s0), min(c1, s1)
                                else:
                                    c0, c1 = posed_interval(prof[p], nprof[p], rho[p], tx, ty,
                                                            tz, u[0], u[1], u[2], px, py, s0,
                                                            s1)
                            if c0 >= c1:
                                continue
                            got = subtract(lo, hi, count, j, i, c0, c1, out, nlo, nhi)
                            if got < 0.0:
                                refused += 1
                            elif got > 0.0:
                                kd = kind[p]
                                dirty = True
                                touched = True
                                rlen[kd] += got
                                rz0[kd] = min(rz0[kd], out[0])
                                rz1[kd] = max(rz1[kd], out[1])
                    if dirty:
                        for kd in range(3):
                            if rlen[kd] > 0.0:
                                _record(st, e, kd, rlen[kd], rz0[kd], rz1[kd], px, py)
                        if rlen[0] > engage:
                            _engaged(st, e, px, py, nxq, nyq, plunge)
            if touched:
                btop[bj - bj0, bi - bi0] = _block_top(
                    lo, hi, count, bi * BLOCK, min(bi * BLOCK + BLOCK, nx) - 1, bj * BLOCK,
                    min(bj * BLOCK + BLOCK, ny) - 1)
    return refused


class _Scratch(NamedTuple):
    boxes: np.ndarray
    out: np.ndarray
    nlo: np.ndarray
    nhi: np.ndarray
    rlen: np.ndarray
    rz0: np.ndarray
    rz1: np.ndarray


@nb.njit(cache=True, parallel=True)
def sweep(lo, hi, count, x0, y0, h, prof, nprof, rho, kind, ptype, rmax, geo, a, b, axis,
          step, engage, win, zlow, start, item):
    """Cut the stock (lo, hi, count) by every item in program order (module docstring).
    Returns the statistics (E, NST) per tile-item pair (row order of `item`) and the cuts
    refused for want of interval slots."""
    ny, nx = count.shape
    ntx = (nx + TILE - 1) // TILE
    nt = start.shape[0] - 1
    P = prof.shape[0]
    cap = lo.shape[2]
    nb_ = TILE // BLOCK
    st = np.zeros((item.shape[0], NST))
    for e in range(item.shape[0]):
        st[e, ST_Q] = np.inf
        st[e, ST_Q + 1] = -np.inf
        st[e, ST_Q + 2] = np.inf
        st[e, ST_Q + 3] = -np.inf
    refused = np.zeros(nt, np.int64)
    for t in nb.prange(nt):
        if start[t + 1] == start[t]:
            continue
        ti0 = (t % ntx) * TILE
        tj0 = (t // ntx) * TILE
        ti1 = min(ti0 + TILE, nx) - 1
        tj1 = min(tj0 + TILE, ny) - 1
        btop = np.full((nb_, nb_), -np.inf)
        for lj in range(nb_):
            for li in range(nb_):
                bi, bj = ti0 + li * BLOCK, tj0 + lj * BLOCK
                if bi <= ti1 and bj <= tj1:
                    btop[lj, li] = _block_top(lo, hi, count, bi, min(bi + BLOCK - 1, ti1), bj,
                                              min(bj + BLOCK - 1, tj1))
        top = -np.inf
        for lj in range(nb_):
            for li in range(nb_):
                top = max(top, btop[lj, li])
        sc = _Scratch(np.empty((P, 6)), np.empty(2), np.empty(2 * cap + 1, np.float32),
                      np.empty(2 * cap + 1, np.float32), np.empty(3), np.empty(3), np.empty(3))
        for e in range(start[t], start[t + 1]):
            s = item[e]
            if zlow[s] >= top:
                continue
            i0 = max(win[s, 0], ti0)
            i1 = min(win[s, 1], ti1)
            j0 = max(win[s, 2], tj0)
            j1 = min(win[s, 3], tj1)
            if i0 > i1 or j0 > j1:
                continue
            refused[t] += _run_item(lo, hi, count, x0, y0, h, prof, nprof, rho, kind, ptype,
                                    rmax, geo, a[s], b[s], axis[s], step, engage, zlow[s], i0,
                                    i1, j0, j1, st, e, btop, ti0 // BLOCK, tj0 // BLOCK, sc)
    return st, refused


@nb.njit(cache=True)
def per_move(st, item, move, n_moves, h):
    """Reduce the tile-item rows to moves: volume (M, 3) mm^3, thickness (M, 3) mm, where
    (M, 3, 3), and the body's engaged width (M,) mm (the largest over the move's items of the
    engaged rays' extent across the travel, plus one ray's h) and engaged ray count (M,)."""
    S = move.shape[0]
    vol = np.zeros((n_moves, 3))
    thick = np.zeros((n_moves, 3))
    where = np.full((n_moves, 3, 3), np.nan)
    q = np.empty((S, 4))
    q[:, 0] = np.inf
    q[:, 1] = -np.inf
    q[:, 2] = np.inf
    q[:, 3] = -np.inf
    for e in range(item.shape[0]):
        s = item[e]
        m = move[s]
        for k in range(3):
            vol[m, k] += st[e, ST_LEN + k] * h * h
            if st[e, ST_THICK + k] > thick[m, k]:
                thick[m, k] = st[e, ST_THICK + k]
                for c in range(3):
                    where[m, k, c] = st[e, ST_WHERE + 3 * k + c]
        q[s, 0] = min(q[s, 0], st[e, ST_Q])
        q[s, 1] = max(q[s, 1], st[e, ST_Q + 1])
        q[s, 2] = min(q[s, 2], st[e, ST_Q + 2])
        q[s, 3] = max(q[s, 3], st[e, ST_Q + 3])
    rays = np.zeros(n_moves, np.int64)
    for e in range(item.shape[0]):
        rays[move[item[e]]] += int(st[e, ST_RAYS])
    width = np.zeros(n_moves)
    for s in range(S):
        if q[s, 1] >= q[s, 0]:
            w = max(q[s, 1] - q[s, 0], q[s, 3] - q[s, 2]) + h
            width[move[s]] = max(width[move[s]], w)
    return vol, thick, where, width, rays
