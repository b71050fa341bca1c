"""Exact penetration depth of a real tool (a union of pieces, `checker.mesh.tool`) into a triangle
mesh (`checker.mesh.bvh.MeshIndex`), per pose; and the allowable cutter size on a mesh.

Definitions (tool frame: tip at the origin, axis +z; r radial distance, h height, mm). A piece is
P = K (+) rho B, K the solid of revolution of a convex half-profile polygon (`tool.py`). For a set
S of triangles the signed value is `signed = -(signed distance between P and S)`: the penetration
depth max over x in S of dist(x, boundary of P) when S meets P, else minus the clearance
dist(S, P). Per triangle T: signed = rho - min over x in T of sd_K(x), sd_K the signed distance
to the core K (negative inside: minus the distance to K's boundary). Where T misses K that is
rho - dist(T, K); where T meets K it is rho + sup{t : T meets K (-) tB}, because a point's depth
in K is its distance to K's boundary.

K in the profile plane: K = {a_i r + b_i h <= c_i} over the sides that are not on the axis
(outer unit normals (a_i, b_i), a_i >= 0: a convex profile with an edge on the axis), and
a_i r(x) + b_i h(x) is 1-Lipschitz in x and grows at rate exactly 1 along (a_i w, b_i) (w the
radial direction), so a point's depth in K is min_i (c_i - a_i r - b_i h) and the erosion
K (-) tB = {a_i r + b_i h <= c_i - t}: the profile clipped by the moved sides (exact for any
convex profile). A degenerate core (a segment on the axis: the ball) has no interior: t* = 0.

Two exact methods (`method=`):
- "slice" (default, `_exact_slice`): sd_K(x) = sd2(r(x), h(x)), sd2 the signed distance in the
  profile plane to the mirrored (convex) profile, convex and even in r, hence nondecreasing in
  r >= 0. On the horizontal slice of T at height h the minimum is at the slice's point nearest
  the axis, r = m(h), m convex, so phi(h) = sd2(m(h), h) is a convex function of one variable
  whose minimum over T's heights is signed's complement: bracketed by tangent lines with
  guaranteed subgradient intervals, to SLICE_EPS (1e-10 mm);
- "gjk" (`_exact`): dist(T, K) by GJK (the triangle's support is its best vertex; K's is the best
  profile vertex swung towards the direction: for a direction (dx, dy, dz), s = |(dx, dy)|, the
  vertex maximising s r_j + dz h_j, at (r_j dx/s, r_j dy/s, h_j)), and t* bracketed with GJK on
  the eroded cores (an intersection at t gives t* >= t; a separation by d at t gives
  t - d <= t* < t since K_t (+) dB lies in K_(t-d)), shrunk by that lower bound, secant steps and
  bisection to EPS_T. Near a contact with a curved rim GJK converges slowly and may not certify a
  separation; it then keeps the upper end of its bracket: it can over-state a depth by ~1e-6 mm.
  It is kept as an independent cross-check of the slice method (tests/test_mesh_depth.py).

Per pose the result is the maximum over the pieces and the triangles, by branch and bound: the BVH
gives the triangles near the piece (its axis segment's box grown by the piece's radius plus rho
minus the best value so far, i.e. at most `reach` of clearance); each gets cheap upper bounds
(the sides' constraints: rho + min_i (c_i - min over T of a_i r + b_i h), with min r over T the
distance from the axis to T's shadow along it; and T's plane against K's support function) and
the exact value is computed only for triangles whose bound beats the best value so far, in order
of that bound (the value at their point nearest the axis is computed first, as a lower bound).
An unbounded piece is clipped per pose at a height above the mesh's box that keeps every
distance within `reach` and every depth.

The depth is measured against the triangles (the mesh's surface), not the solid they enclose: a
tool entirely inside a closed mesh reports its clearance to the surface.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from checker.mesh.bvh import STACK, MeshIndex, query_capsule
from checker.mesh.tool import ToolPieces, body_profiles, body_top, drop_repeats

GJK_EPS = 1e-11     # mm: GJK stops when its upper and lower distance bounds are this close
GJK_TOUCH = 1e-10   # mm: a distance below this counts as touching (t* then has this error)
GJK_ITER = 100
EPS_T = 1e-10       # mm: width of the final bracket on the erosion depth t*
NBOUND = 16         # per candidate: upper, lower bound, t* bound, point xyz, triangle (9)
_PV = 24            # profile vertices after clipping, at most (MAXV + clips)
EPS_H = 1e-9        # as checker.kernels.EPS_H: a normal this close to the axis is vertical


@dataclass
class PoseDepths:
    """Per pose: `depth (N,)` mm (> 0 penetration depth, < 0 clearance, -reach when nothing is
    within reach), `piece (N,)` kind of the deepest piece (0 body, 1 shank, 2 holder; -1 when
    depth <= 0), `triangle (N,)` index of the deepest (or nearest) triangle (-1 when nothing is
    within reach), `point (N, 3)` the deepest (or nearest) point of the mesh on it, mm, part frame
    (nan when nothing is within reach)."""

    depth: np.ndarray
    piece: np.ndarray
    triangle: np.ndarray
    point: np.ndarray


# ---- profile polygons (r, h) ---------------------------------------------------------------


@nb.njit(cache=True)
def _clip(P, m, nr, nh, c, out):
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
def _constraints(P, m, cn, cc):
    """The sides of P[:m] that are not on the axis: outer unit normals cn (a, b) with a >= 0 and
    offsets cc (a r + b h <= c); returns (count, solid) where solid means P has an interior."""
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
        cn[nc, 0], cn[nc, 1] = a, b
        cc[nc] = a * r0 + b * h0
        nc += 1
    return nc, (nc > 0 and area > 0.0)


@nb.njit(cache=True)
def _erode(P, m, cn, cc, nc, t, buf_a, buf_b):
    """The profile of K (-) tB: P[:m] clipped by every side moved in by t. Returns (polygon,
    count); the polygon is one of the two buffers."""
    src = P
    cnt = m
    use_a = True
    for i in range(nc):
        dst = buf_a if use_a else buf_b
        cnt = _clip(src, cnt, cn[i, 0], cn[i, 1], cc[i] - t, dst)
        src = dst
        use_a = not use_a
        if cnt == 0:
            break
    return src, cnt


@nb.njit(cache=True, inline="always")
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
def _sd(P, m, cn, cc, nc, solid, t, r, h):
    """Signed distance from (r, h) (r >= 0) to the profile of K (-) tB (P[:m] is that profile;
    cn, cc the sides of K): negative inside (minus the depth min_i (c_i - t - a_i r - b_i h)),
    else the distance to the polygon; and the nearest profile point (the point itself inside)."""
    if solid:
        g = np.inf
        for i in range(nc):
            g = min(g, cc[i] - t - (cn[i, 0] * r + cn[i, 1] * h))
        if g >= 0.0:
            return -g, r, h
    if m == 0:
        return np.inf, r, h
    best, qr, qh = _nearest_on_profile(P, m, r, h)
    return math.sqrt(best), qr, qh


@nb.njit(cache=True)
def _lift(x, y, qr, qh):
    """The point at radius qr, height qh in the meridian half-plane of (x, y)."""
    rr = math.sqrt(x * x + y * y)
    if rr > 0.0:
        return qr * x / rr, qr * y / rr, qh
    return qr, 0.0, qh


# ---- GJK: distance between a triangle and a solid of revolution ------------------------------


@nb.njit(cache=True)
def _support(P, m, dx, dy, dz):
    """Support point of the solid of revolution of P[:m] in direction (dx, dy, dz)."""
    s = math.sqrt(dx * dx + dy * dy)
    j = 0
    best = -np.inf
    for k in range(m):
        v = s * P[k, 0] + dz * P[k, 1]
        if v > best:
            best, j = v, k
    r = P[j, 0]
    if s > 0.0:
        return r * dx / s, r * dy / s, P[j, 1]
    return r, 0.0, P[j, 1]


@nb.njit(cache=True)
def _seg_w(ax, ay, az, bx, by, bz):
    """Weights (u, v) of the point of segment ab nearest the origin."""
    ex, ey, ez = bx - ax, by - ay, bz - az
    d = ex * ex + ey * ey + ez * ez
    if d <= 0.0:
        return 1.0, 0.0
    s = -(ax * ex + ay * ey + az * ez) / d
    s = min(1.0, max(0.0, s))
    return 1.0 - s, s


@nb.njit(cache=True)
def _tri_w(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Weights (u, v, w) of the point of triangle abc nearest the origin (Ericson, Real-Time
    Collision Detection 5.1.5), falling back to the edges for a (nearly) degenerate triangle."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    ab2 = abx * abx + aby * aby + abz * abz
    ac2 = acx * acx + acy * acy + acz * acz
    abac = abx * acx + aby * acy + abz * acz
    if ab2 * ac2 - abac * abac <= 1e-20 * ab2 * ac2 or ab2 == 0.0 or ac2 == 0.0:
        return _tri_edges(ax, ay, az, bx, by, bz, cx, cy, cz)
    d1 = -(abx * ax + aby * ay + abz * az)
    d2 = -(acx * ax + acy * ay + acz * az)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0
    d3 = -(abx * bx + aby * by + abz * bz)
    d4 = -(acx * bx + acy * by + acz * bz)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        den = d1 - d3
        v = d1 / den if den > 0.0 else 0.0
        return 1.0 - v, v, 0.0
    d5 = -(abx * cx + aby * cy + abz * cz)
    d6 = -(acx * cx + acy * cy + acz * cz)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        den = d2 - d6
        w = d2 / den if den > 0.0 else 0.0
        return 1.0 - w, 0.0, w
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        den = (d4 - d3) + (d5 - d6)
        w = (d4 - d3) / den if den > 0.0 else 0.0
        return 0.0, 1.0 - w, w
    den = va + vb + vc
    if den > 0.0:
        v = vb / den
        w = vc / den
        return 1.0 - v - w, v, w
    return _tri_edges(ax, ay, az, bx, by, bz, cx, cy, cz)


@nb.njit(cache=True)
def _tri_edges(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Weights of the point nearest the origin on the edges of a degenerate triangle."""
    u1, v1 = _seg_w(ax, ay, az, bx, by, bz)
    p1 = (u1 * ax + v1 * bx) ** 2 + (u1 * ay + v1 * by) ** 2 + (u1 * az + v1 * bz) ** 2
    u2, w2 = _seg_w(ax, ay, az, cx, cy, cz)
    p2 = (u2 * ax + w2 * cx) ** 2 + (u2 * ay + w2 * cy) ** 2 + (u2 * az + w2 * cz) ** 2
    v3, w3 = _seg_w(bx, by, bz, cx, cy, cz)
    p3 = (v3 * bx + w3 * cx) ** 2 + (v3 * by + w3 * cy) ** 2 + (v3 * bz + w3 * cz) ** 2
    if p1 <= p2 and p1 <= p3:
        return u1, v1, 0.0
    if p2 <= p3:
        return u2, 0.0, w2
    return 0.0, v3, w3


@nb.njit(cache=True)
def _tet_w(W, lam):
    """Weights of the point of the tetrahedron W[0:4] nearest the origin into lam[0:4] (lam[4:12]
    scratch); returns True when the origin is inside (lam its barycentric coordinates)."""
    best = np.inf
    inside = True
    bary = lam[4:8]
    tmp = lam[8:12]
    bary[:] = 0.0
    tmp[:] = 0.0
    for f in range(4):
        if f == 0:
            i, j, k, o = 0, 1, 2, 3
        elif f == 1:
            i, j, k, o = 0, 3, 1, 2
        elif f == 2:
            i, j, k, o = 0, 2, 3, 1
        else:
            i, j, k, o = 1, 3, 2, 0
        e1x, e1y, e1z = W[j, 0] - W[i, 0], W[j, 1] - W[i, 1], W[j, 2] - W[i, 2]
        e2x, e2y, e2z = W[k, 0] - W[i, 0], W[k, 1] - W[i, 1], W[k, 2] - W[i, 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        so = -(nx * W[i, 0] + ny * W[i, 1] + nz * W[i, 2])
        sd = nx * (W[o, 0] - W[i, 0]) + ny * (W[o, 1] - W[i, 1]) + nz * (W[o, 2] - W[i, 2])
        scale = math.sqrt((nx * nx + ny * ny + nz * nz) * (
            (W[o, 0] - W[i, 0]) ** 2 + (W[o, 1] - W[i, 1]) ** 2 + (W[o, 2] - W[i, 2]) ** 2))
        # a thin tetrahedron (support points bunch up on a curved rim) cannot decide inside:
        # its faces decide the nearest point instead (touching is then a tiny distance)
        degenerate = abs(sd) <= 1e-9 * scale or sd == 0.0
        if not degenerate:
            bary[o] = so / sd
        if degenerate or so * sd < 0.0:
            inside = False
            u, v, w = _tri_w(W[i, 0], W[i, 1], W[i, 2], W[j, 0], W[j, 1], W[j, 2],
                             W[k, 0], W[k, 1], W[k, 2])
            px = u * W[i, 0] + v * W[j, 0] + w * W[k, 0]
            py = u * W[i, 1] + v * W[j, 1] + w * W[k, 1]
            pz = u * W[i, 2] + v * W[j, 2] + w * W[k, 2]
            d2 = px * px + py * py + pz * pz
            if d2 < best:
                best = d2
                tmp[:] = 0.0
                tmp[i], tmp[j], tmp[k] = u, v, w
    if inside:
        s = 0.0
        for q in range(4):
            lam[q] = max(bary[q], 0.0)
            s += lam[q]
        if s > 0.0:
            for q in range(4):
                lam[q] /= s
        else:
            lam[0:4] = 0.25
        return True
    for q in range(4):
        lam[q] = tmp[q]
    return False


@nb.njit(cache=True)
def _reduce(W, A, lam, n):
    """Nearest point v of the simplex W[:n] to the origin; keep the vertices that support it
    (W, A, lam compacted). Returns (n, vx, vy, vz, inside)."""
    inside = False
    if n == 1:
        lam[0] = 1.0
    elif n == 2:
        lam[0], lam[1] = _seg_w(W[0, 0], W[0, 1], W[0, 2], W[1, 0], W[1, 1], W[1, 2])
    elif n == 3:
        lam[0], lam[1], lam[2] = _tri_w(W[0, 0], W[0, 1], W[0, 2], W[1, 0], W[1, 1], W[1, 2],
                                        W[2, 0], W[2, 1], W[2, 2])
    else:
        inside = _tet_w(W, lam)
    vx = vy = vz = 0.0
    for k in range(n):
        vx += lam[k] * W[k, 0]
        vy += lam[k] * W[k, 1]
        vz += lam[k] * W[k, 2]
    if inside:
        return n, 0.0, 0.0, 0.0, True
    q = 0
    for k in range(n):
        if lam[k] > 0.0:
            if q != k:
                for a in range(3):
                    W[q, a] = W[k, a]
                    A[q, a] = A[k, a]
                lam[q] = lam[k]
            q += 1
    if q == 0:
        q = 1
        lam[0] = 1.0
    return q, vx, vy, vz, False


@nb.njit(cache=True)
def _gjk(T, P, m, thresh, x0x, x0y, x0z, y0x, y0y, y0z, W, A, lam, res):
    """Distance between the triangle T (3, 3) (or any convex polytope: its vertices (k, 3)) and
    the solid of revolution of P[:m] (tool frame), starting from x0 in T and y0 in the solid.
    Returns 0 separated (0 < res[0] <= distance <= res[1]), 1 intersecting or closer than
    GJK_TOUCH (res[0] = res[1] = 0), 2 farther than `thresh` (res[0] > thresh), 3 stopped
    (rounding, iterations) with no positive lower bound: 0 <= distance <= res[1], intersection
    not excluded; res[2:5] the point of T nearest the solid (a common point when intersecting)."""
    W[0, 0], W[0, 1], W[0, 2] = x0x - y0x, x0y - y0y, x0z - y0z
    A[0, 0], A[0, 1], A[0, 2] = x0x, x0y, x0z
    lam[0] = 1.0
    n = 1
    vx, vy, vz = W[0, 0], W[0, 1], W[0, 2]
    lb = 0.0
    status = 0
    for _ in range(GJK_ITER):
        vv = vx * vx + vy * vy + vz * vz
        if vv <= GJK_TOUCH * GJK_TOUCH:
            status = 1      # touching within GJK_TOUCH: counted as meeting
            break
        vn = math.sqrt(vv)
        j = 0
        dmin = vx * T[0, 0] + vy * T[0, 1] + vz * T[0, 2]
        for k in range(1, T.shape[0]):
            d = vx * T[k, 0] + vy * T[k, 1] + vz * T[k, 2]
            if d < dmin:
                dmin, j = d, k
        bx, by, bz = _support(P, m, vx, vy, vz)
        wx, wy, wz = T[j, 0] - bx, T[j, 1] - by, T[j, 2] - bz
        vw = vx * wx + vy * wy + vz * wz
        if vw > lb * vn:
            lb = vw / vn
        if lb > thresh:
            res[0], res[1] = lb, vn
            status = 2
            break
        if vn - lb <= GJK_EPS + 1e-13 * vn:
            break
        dup = False
        for k in range(n):
            if W[k, 0] == wx and W[k, 1] == wy and W[k, 2] == wz:
                dup = True
        if dup:
            break
        W[n, 0], W[n, 1], W[n, 2] = wx, wy, wz
        A[n, 0], A[n, 1], A[n, 2] = T[j, 0], T[j, 1], T[j, 2]
        n += 1
        n, nx_, ny_, nz_, inside = _reduce(W, A, lam, n)
        if inside:
            if lb > GJK_TOUCH:
                break       # contradicts the certified lower bound: rounding; keep v
            status = 1
            break
        if nx_ * nx_ + ny_ * ny_ + nz_ * nz_ >= vv:
            break   # no progress: rounding
        vx, vy, vz = nx_, ny_, nz_
    px = py = pz = 0.0
    for k in range(n):
        px += lam[k] * A[k, 0]
        py += lam[k] * A[k, 1]
        pz += lam[k] * A[k, 2]
    res[2], res[3], res[4] = px, py, pz
    if status == 1:
        res[0], res[1] = 0.0, 0.0
    elif status == 0:
        res[0], res[1] = lb, math.sqrt(vx * vx + vy * vy + vz * vz)
        if lb <= 0.0:
            status = 3
    return status


# ---- one triangle ----------------------------------------------------------------------------


@nb.njit(cache=True)
def _plane_upper(T, nx, ny, nz, P, m, rho):
    """Upper bound of the signed value of triangle T (unit normal n, tool frame) from its plane:
    rho - max(d+, d-), d+- the distances by which the core K lies beyond the plane on either
    side (support function h_K): dist(T, K) >= d+- when positive, and where the plane cuts K,
    K (-) tB meets it only while t <= -d+ and t <= -d- (h_(K (-) tB) <= h_K - t)."""
    s = math.sqrt(nx * nx + ny * ny)
    hp = -np.inf
    hm = -np.inf
    for k in range(m):
        hp = max(hp, s * P[k, 0] + nz * P[k, 1])
        hm = max(hm, s * P[k, 0] - nz * P[k, 1])
    c = nx * T[0, 0] + ny * T[0, 1] + nz * T[0, 2]
    return rho - max(-hm - c, c - hp)


@nb.njit(cache=True, inline="always")
def _slack(T, cn, cc, nc, solid, rmin, rmax, hlo, hhi):
    """min_i (c_i - min over T of (a_i r + b_i h)) with T's least distance `rmin` from the axis
    (a degenerate core: the bounding cylinder's sides, at most 0), mm. T: the vertices of a
    triangle, or of any convex polytope (rows)."""
    hmin, hmax = T[0, 2], T[0, 2]
    for k in range(1, T.shape[0]):
        hmin, hmax = min(hmin, T[k, 2]), max(hmax, T[k, 2])
    if solid:
        ub = np.inf
        for i in range(nc):
            a, b = cn[i, 0], cn[i, 1]
            fmin = a * rmin + (b * hmin if b >= 0.0 else b * hmax)
            ub = min(ub, cc[i] - fmin)
        return ub
    return min(0.0, min(rmax - rmin, min(hmax - hlo, hhi - hmin)))


@nb.njit(cache=True)
def _quick_upper(T, cn, cc, nc, solid, rho, rmax, hlo, hhi):
    """A cheaper, looser `_upper`: min r over T bounded below by the distance from the axis to
    the box of T's shadow (T: a triangle's vertices, or any convex polytope's)."""
    x0, x1, y0, y1 = T[0, 0], T[0, 0], T[0, 1], T[0, 1]
    for k in range(1, T.shape[0]):
        x0, x1 = min(x0, T[k, 0]), max(x1, T[k, 0])
        y0, y1 = min(y0, T[k, 1]), max(y1, T[k, 1])
    dx = max(x0, max(-x1, 0.0))
    dy = max(y0, max(-y1, 0.0))
    rmin = math.sqrt(dx * dx + dy * dy)
    return rho + _slack(T, cn, cc, nc, solid, rmin, rmax, hlo, hhi)


@nb.njit(cache=True)
def _shadow_w(T):
    """Weights (u, v, w) of a point of triangle T (tool frame) whose shadow along the axis is
    nearest the axis, and whether the axis meets the shadow (the three edges see it on one
    side; then the weights are its barycentric ones), else the nearest point of the nearest
    edge. Robust for slivers (a wall seen edge-on, whose shadow is a segment to rounding):
    Ericson's regions (`_tri_w`) decide from differences of products that rounding swamps
    there, which put the point 2 mm from the axis where the shadow crosses it; here a sliver
    the axis meets to rounding is met (its weights may then be anywhere on T), and one it
    misses to rounding has an edge within rounding of the axis."""
    ax, ay, bx, by, cx, cy = T[0, 0], T[0, 1], T[1, 0], T[1, 1], T[2, 0], T[2, 1]
    wa = bx * cy - by * cx  # twice the signed areas of (axis, b, c), (axis, c, a), (axis, a, b)
    wb = cx * ay - cy * ax
    wc = ax * by - ay * bx
    total = wa + wb + wc
    if total != 0.0 and ((wa >= 0.0 and wb >= 0.0 and wc >= 0.0)
                         or (wa <= 0.0 and wb <= 0.0 and wc <= 0.0)):
        return wa / total, wb / total, wc / total, True
    u, v, w = _tri_edges(ax, ay, 0.0, bx, by, 0.0, cx, cy, 0.0)
    return u, v, w, False


@nb.njit(cache=True)
def _upper(T, cn, cc, nc, solid, rho, rmax, hlo, hhi, out):
    """Upper bound (out[0]) of the signed value of triangle T (tool frame) against the piece,
    the upper bound of t* (out[2]) and a point of T whose shadow is nearest the axis
    (out[3:6], `_shadow_w`): rho + min_i (c_i - min over T of (a_i r + b_i h)), with min r =
    the distance from the axis to T's shadow along it (a degenerate core: the bounding
    cylinder's sides, at most 0)."""
    u, v, w, met = _shadow_w(T)
    xx = u * T[0, 0] + v * T[1, 0] + w * T[2, 0]
    xy = u * T[0, 1] + v * T[1, 1] + w * T[2, 1]
    rmin = 0.0 if met else math.sqrt(xx * xx + xy * xy)
    ub = _slack(T, cn, cc, nc, solid, rmin, rmax, hlo, hhi)
    out[0] = rho + ub
    out[2] = ub
    out[3], out[4] = xx, xy
    out[5] = u * T[0, 2] + v * T[1, 2] + w * T[2, 2]


@nb.njit(cache=True)
def _lower(T, P, m, cn, cc, nc, solid, rho, out):
    """Lower bound (out[1]) of the signed value of triangle T: the exact value at its point
    nearest the axis (out[3:6], from `_upper`; exact for a floor under a flat bottom)."""
    x0, y0, z0 = out[3], out[4], out[5]
    sd, _, _ = _sd(P, m, cn, cc, nc, solid, 0.0, math.sqrt(x0 * x0 + y0 * y0), z0)
    out[1] = min(rho - sd, out[0])


@nb.njit(cache=True)
def _exact(T, P, m, cn, cc, nc, solid, rho, best, bnd, W, A, lam, res, buf_a, buf_b, wit):
    """Signed value of triangle T against the piece if it beats `best` by more than EPS_T
    (returned, its point in wit[0:3]), else -inf. bnd: the triangle's `_upper` and `_lower`."""
    lval = bnd[1]
    wx, wy, wz = bnd[3], bnd[4], bnd[5]
    ub_in = bnd[2]
    need = best - rho                  # t* must exceed this
    lo = -np.inf                       # t* >= lo, with a point of T at that depth (wit)
    if lval - rho >= 0.0:
        lo = lval - rho
    wit[0], wit[1], wit[2] = wx, wy, wz
    if need < 0.0 and lo < 0.0:
        # is T within reach of K at all? GJK from the best sample point
        sd, qr, qh = _sd(P, m, cn, cc, nc, solid, 0.0, math.sqrt(wx * wx + wy * wy), wz)
        y0x, y0y, y0z = _lift(wx, wy, qr, qh)
        st = _gjk(T, P, m, -need, wx, wy, wz, y0x, y0y, y0z, W, A, lam, res)
        if st == 2:
            return -np.inf
        if st == 0:
            val = rho - res[0]
            if val > best:
                wit[0], wit[1], wit[2] = res[2], res[3], res[4]
                return val
            return -np.inf
        lo = 0.0            # st 1, or 3 (not certified, within res[1]): taken as touching
        wit[0], wit[1], wit[2] = res[2], res[3], res[4]
    if not solid:
        if lo >= 0.0 and rho > best:
            return rho
        return -np.inf
    hi = ub_in
    # bracket [lo, hi] on t*; separated probes (t, d) for the secant
    t1 = d1 = t2 = d2 = 0.0
    npairs = 0
    bisect = False
    first = True
    for _ in range(200):
        if hi <= need + EPS_T or hi <= lo:
            if hi <= need + EPS_T:
                return -np.inf
            break
        if lo > need and hi - lo <= EPS_T:
            break
        if lo <= need:
            tp = max(need, lo) + 0.5 * EPS_T       # does T beat the best at all?
        elif first:
            tp = hi
        elif bisect or npairs == 0:
            tp = 0.5 * (lo + hi)
        elif npairs == 1:
            tp = t2 - d2 + 0.5 * EPS_T
        else:
            tp = t2 - d2 * (t2 - t1) / (d2 - d1) + 0.5 * EPS_T if d2 != d1 else 0.5 * (lo + hi)
        if not (tp > lo and tp <= hi):
            tp = 0.5 * (lo + hi)
        first = False
        width = hi - lo
        Q, mq = _erode(P, m, cn, cc, nc, tp, buf_a, buf_b)

        if mq == 0:
            hi = tp
            bisect = True
            continue
        sd, qr, qh = _sd(Q, mq, cn, cc, nc, solid, tp, math.sqrt(wit[0] ** 2 + wit[1] ** 2),
                         wit[2])
        if sd <= 0.0:
            lo = tp
            bisect = hi - lo > 0.5 * width
            continue
        y0x, y0y, y0z = _lift(wit[0], wit[1], qr, qh)
        st = _gjk(T, Q, mq, np.inf, wit[0], wit[1], wit[2], y0x, y0y, y0z, W, A, lam, res)
        if st == 1:
            lo = tp
            wit[0], wit[1], wit[2] = res[2], res[3], res[4]
        elif st == 3:
            if tp - res[1] > lo:           # not certified: only the lower bound
                lo = tp - res[1]
                wit[0], wit[1], wit[2] = res[2], res[3], res[4]
        else:
            hi = tp
            d = res[1]
            if tp - d > lo:
                lo = tp - d
                wit[0], wit[1], wit[2] = res[2], res[3], res[4]
            t1, d1 = t2, d2
            t2, d2 = tp, d
            npairs += 1
        bisect = hi - lo > 0.5 * width
    if lo <= need:
        return -np.inf
    return rho + hi



@nb.njit(cache=True)
def _sd_grad(P, m, cn, cc, nc, solid, r, h):
    """Signed distance from (r, h) to the profile of K (P[:m], sides cn, cc) and its gradient
    (a subgradient where it has a kink)."""
    if solid:
        g = np.inf
        ia = 0
        for i in range(nc):
            gi = cc[i] - (cn[i, 0] * r + cn[i, 1] * h)
            if gi < g:
                g, ia = gi, i
        if g >= 0.0:
            return -g, cn[ia, 0], cn[ia, 1]
    best, qr, qh = _nearest_on_profile(P, m, r, h)
    d = math.sqrt(best)
    if d > 0.0:
        return d, (r - qr) / d, (h - qh) / d
    return 0.0, 0.0, 0.0


@nb.njit(cache=True)
def _slice_eval(T, i0, i1, i2, s1, s, P, m, cn, cc, nc, solid, out):
    """phi(s) = signed distance to K of the point nearest the axis on the slice of T at level s
    (s = 0 at vertex i0, s1 at i1, 1 at i2; heights affine in s), an interval [out[1], out[2]]
    that contains the subdifferential of phi at s, and that point (out[3:6]).

    m(s), the slice's distance from the axis, has the derivative u . (E' + w D') (Danskin; u the
    unit direction to the nearest point E + w D of the slice E..F, D = F - E); where the slice
    is short (a vertex) its nearest point is any of it: the interval spans w = 0 and w = 1;
    where m is about 0 it is [-C, C], C the Lipschitz constant of m."""
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
    sd, gr, gh = _sd_grad(P, m, cn, cc, nc, solid, r, h)
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
    out[0] = sd
    out[1] = gr * mlo + gh * dh
    out[2] = gr * mhi + gh * dh
    out[3], out[4], out[5] = qx, qy, h


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


NSTACK = 64
NBR = 11            # per bracket: a, f(a), slope, b, f(b), slope, probes without halving,
#                     next step (0 tangents, 1 secant), end replaced last, Illinois scales


@nb.njit(cache=True)
def _fresh(br, k):
    br[k, 6] = 0.0
    br[k, 7] = 0.0
    br[k, 8] = 0.0
    br[k, 9] = 1.0
    br[k, 10] = 1.0


@nb.njit(cache=True)
def _illinois(br, k, side, poor):
    """Bookkeeping after end `side` (-1 a, +1 b) of bracket k was replaced; `poor`: the bracket
    did not halve."""
    br[k, 6] = br[k, 6] + 1.0 if poor else 0.0
    if side > 0.0:
        br[k, 10] = 1.0
        if br[k, 8] > 0.0:
            br[k, 9] *= 0.5
    else:
        br[k, 9] = 1.0
        if br[k, 8] < 0.0:
            br[k, 10] *= 0.5
    br[k, 8] = side
SLICE_EPS = 1e-10   # mm: the slice minimisation stops when its bounds are this close


@nb.njit(cache=True)
def _exact_slice(T, P, m, cn, cc, nc, solid, rho, best, ev, br, wit):
    """Signed value of triangle T against the piece, rho - min over T of the signed distance to
    K, if it beats `best` (returned, its point in wit[0:3]), else -inf. `ev (7,)`, `br (NSTACK,
    NBR)` scratch.

    The signed distance to the convex solid of revolution K is sd2(r, h), the signed distance in
    the profile plane to the (mirrored, convex) profile: convex and even in r, so nondecreasing
    in r >= 0. On the horizontal slice of T at height h its minimum is therefore at the slice's
    point nearest the axis, at r = m(h), and m is convex (a partial minimum of the convex r
    over a convex set): phi(h) = sd2(m(h), h) is convex (sd2 convex, nondecreasing in r). Its
    minimum over the triangle's heights (a level s in [0, 1] affine in the height) is bracketed
    by tangent lines (each evaluation gives an interval holding phi's subgradients; a bracket
    whose probe's interval holds 0 is split in two), probing in turn where the end tangents
    meet (exact at a kink between two straight pieces) and where the secant of phi' vanishes
    (exact for a parabola; the Illinois rule keeps it from converging from one side only), or
    halving after four probes that did not halve a bracket, until the best value found is within
    SLICE_EPS of the lowest bracket bound, or that bound shows T cannot beat `best`."""
    i0, i1, i2 = 0, 1, 2
    if T[i1, 2] < T[i0, 2]:
        i0, i1 = i1, i0
    if T[i2, 2] < T[i1, 2]:
        i1, i2 = i2, i1
    if T[i1, 2] < T[i0, 2]:
        i0, i1 = i1, i0
    zr = T[i2, 2] - T[i0, 2]
    s1 = (T[i1, 2] - T[i0, 2]) / zr if zr > 0.0 else 0.5
    thresh = rho - best            # phi must go below this
    _slice_eval(T, i0, i1, i2, s1, 0.0, P, m, cn, cc, nc, solid, ev)
    fbest = ev[0]
    wit[0], wit[1], wit[2] = ev[3], ev[4], ev[5]
    br[0, 0], br[0, 1], br[0, 2] = 0.0, ev[0], ev[1]
    _slice_eval(T, i0, i1, i2, s1, 1.0, P, m, cn, cc, nc, solid, ev)
    if ev[0] < fbest:
        fbest = ev[0]
        wit[0], wit[1], wit[2] = ev[3], ev[4], ev[5]
    br[0, 3], br[0, 4], br[0, 5] = 1.0, ev[0], ev[2]
    _fresh(br, 0)
    nbr = 1
    conservative = False
    for _ in range(400):
        kmin = -1
        lmin = np.inf
        hmin = 0.0
        for k in range(nbr):
            lb, hc = _bracket_low(br[k, 0], br[k, 1], br[k, 2], br[k, 3], br[k, 4], br[k, 5])
            if lb < lmin:
                lmin, kmin, hmin = lb, k, hc
        if kmin < 0 or lmin >= thresh:
            if kmin >= 0 or fbest >= thresh:
                return -np.inf
            break
        if fbest - lmin <= SLICE_EPS:
            break
        a, ga = br[kmin, 0], br[kmin, 2]
        b, fb, gb = br[kmin, 3], br[kmin, 4], br[kmin, 5]
        if b - a <= 4e-16 or ga >= 0.0 or gb <= 0.0:
            # exhausted (its ends are evaluated): drop it
            for c in range(NBR):
                br[kmin, c] = br[nbr - 1, c]
            nbr -= 1
            continue
        # in turn: the tangents' meeting (exact at a kink) and the secant on phi' (exact for a
        # parabola; Illinois: the slope of an end kept twice is halved); halving after four
        # probes that did not halve the bracket
        if br[kmin, 7] > 0.0:
            sa, sb = ga * br[kmin, 9], gb * br[kmin, 10]
            hc = a - sa * (b - a) / (sb - sa)
        else:
            hc = hmin
        br[kmin, 7] = 1.0 - br[kmin, 7]
        if br[kmin, 6] >= 4.0 or not (hc > a and hc < b):
            hc = 0.5 * (a + b)
            br[kmin, 6] = 0.0
        _slice_eval(T, i0, i1, i2, s1, hc, P, m, cn, cc, nc, solid, ev)
        ev[6] += 1.0                             # evaluations, for statistics
        if ev[0] < fbest:
            fbest = ev[0]
            wit[0], wit[1], wit[2] = ev[3], ev[4], ev[5]
        width = b - a
        if ev[1] > 0.0:                          # the minimum is left of hc
            br[kmin, 3], br[kmin, 4], br[kmin, 5] = hc, ev[0], ev[2]
            _illinois(br, kmin, 1.0, hc - a > 0.5 * width)
        elif ev[2] < 0.0:                        # right of hc
            br[kmin, 0], br[kmin, 1], br[kmin, 2] = hc, ev[0], ev[1]
            _illinois(br, kmin, -1.0, b - hc > 0.5 * width)
        elif nbr < NSTACK:                       # either side: split
            br[kmin, 3], br[kmin, 4], br[kmin, 5] = hc, ev[0], ev[2]
            br[nbr, 0], br[nbr, 1], br[nbr, 2] = hc, ev[0], ev[1]
            br[nbr, 3], br[nbr, 4], br[nbr, 5] = b, fb, gb
            _fresh(br, kmin)
            _fresh(br, nbr)
            nbr += 1
        else:
            conservative = True
            break
    if conservative:
        fbest = min(fbest, lmin)     # a lower bound of the minimum: never shallow
    val = rho - fbest
    if val > best:
        return val
    return -np.inf


# ---- poses -------------------------------------------------------------------------------


@nb.njit(cache=True)
def _frame(ax, ay, az):
    n = math.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / n, ay / n, az / n
    if abs(ax) < 0.9:
        rx, ry, rz = 1.0, 0.0, 0.0
    else:
        rx, ry, rz = 0.0, 1.0, 0.0
    # e1 = normalize(r - (r.a) a)
    d = rx * ax + ry * ay + rz * az
    e1x, e1y, e1z = rx - d * ax, ry - d * ay, rz - d * az
    n1 = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    e1x, e1y, e1z = e1x / n1, e1y / n1, e1z / n1
    e2x = ay * e1z - az * e1y
    e2y = az * e1x - ax * e1z
    e2z = ax * e1y - ay * e1x
    return e1x, e1y, e1z, e2x, e2y, e2z, ax, ay, az


@nb.njit(cache=True)
def _in_tool_frame(tv, t, px, py, pz, e1x, e1y, e1z, e2x, e2y, e2z, ex, ey, ez, T):
    """Triangle t's vertices `tv[t]` (part frame) into rows 0-2 of T in the tool frame with tip
    p and axes e1, e2, e (mm)."""
    for v in range(3):
        dx, dy, dz = tv[t, v, 0] - px, tv[t, v, 1] - py, tv[t, v, 2] - pz
        T[v, 0] = dx * e1x + dy * e1y + dz * e1z
        T[v, 1] = dx * e2x + dy * e2y + dz * e2z
        T[v, 2] = dx * ex + dy * ey + dz * ez


@nb.njit(cache=True)
def _box_top(mlo, mhi, px, py, pz, ex, ey, ez):
    """The highest corner of the mesh's box above the point p along the axis e, mm."""
    hm = -np.inf
    for c in range(8):
        qx = mhi[0] if c & 1 else mlo[0]
        qy = mhi[1] if c & 2 else mlo[1]
        qz = mhi[2] if c & 4 else mlo[2]
        hm = max(hm, (qx - px) * ex + (qy - py) * ey + (qz - pz) * ez)
    return hm


@nb.njit(cache=True)
def _piece_core(prof, nprof, p, h1, P, Pc, cn, cc):
    """Piece p's core profile clipped for a pose into Pc: an unbounded piece cut first at h1
    (above the mesh, with room for what is measured), then at h1 plus its radius there (room
    for depths); its sides into cn, cc. Returns (count, sides, solid, rmax, hlo, hhi): the
    clipped profile's vertex count, the sides, whether it has an interior, its radius and
    height range (mm)."""
    m0 = nprof[p]
    for k in range(m0):
        P[k, 0], P[k, 1] = prof[p, k, 0], prof[p, k, 1]
    mc = _clip(P, m0, 0.0, 1.0, h1, Pc)
    rr = 0.0
    for k in range(mc):
        rr = max(rr, Pc[k, 0])
    mc = _clip(P, m0, 0.0, 1.0, h1 + rr, Pc)
    if mc == 0:
        return 0, 0, False, 0.0, 0.0, 0.0
    nc, solid = _constraints(Pc, mc, cn, cc)
    rmax, hlo, hhi = 0.0, np.inf, -np.inf
    for k in range(mc):
        rmax = max(rmax, Pc[k, 0])
        hlo = min(hlo, Pc[k, 1])
        hhi = max(hhi, Pc[k, 1])
    return mc, nc, solid, rmax, hlo, hhi


@nb.njit(cache=True)
def _pose(i, node_lo, node_hi, node_left, node_right, node_start, node_count, tv, tn, tid, mlo,
          mhi, prof, nprof, rho, kind, tool_ptr, pose_tool, tips, axes, floor, reach, method,
          out_d, out_piece, out_tri, out_pt, stats, cand, bnd, order, stack, P, Pc, cn, cc, T, W,
          A, lam, res, buf_a, buf_b, wit, ev, br, bq):
    """One pose: the branch and bound over the pieces and the BVH's candidates. Returns the
    candidate buffers (grown when needed)."""
    px, py, pz = tips[i, 0], tips[i, 1], tips[i, 2]
    e1x, e1y, e1z, e2x, e2y, e2z, ex, ey, ez = _frame(axes[i, 0], axes[i, 1], axes[i, 2])
    best = floor
    best_tri = -1
    best_piece = -1
    bx = by = bz = np.nan
    hm = _box_top(mlo, mhi, px, py, pz, ex, ey, ez)
    tool = pose_tool[i]
    for p in range(tool_ptr[tool], tool_ptr[tool + 1]):
        rp = rho[p]
        # an unbounded piece clipped above the mesh, with room for distances within reach
        mc, nc, solid, rmax, hlo, hhi = _piece_core(prof, nprof, p,
                                                    hm + rp + max(reach, 0.0) + 1.0, P, Pc,
                                                    cn, cc)
        if mc == 0:
            continue
        pad = rmax + max(rp - best, 0.0) + 1e-9
        s0x, s0y, s0z = px + hlo * ex, py + hlo * ey, pz + hlo * ez
        L = hhi - hlo
        cand, k_c = query_capsule(node_lo, node_hi, node_left, node_right, node_start,
                                  node_count, s0x, s0y, s0z, L * ex, L * ey, L * ez, pad, cand,
                                  stack)
        stats[i, 0] += k_c
        if k_c == 0:
            continue
        if bnd.shape[0] < k_c:
            bnd = np.empty((cand.shape[0], bnd.shape[1]))
            order = np.empty(cand.shape[0], dtype=np.int64)
        nkeep = 0
        for q in range(k_c):
            t = cand[q]
            _in_tool_frame(tv, t, px, py, pz, e1x, e1y, e1z, e2x, e2y, e2z, ex, ey, ez, T)
            nx = tn[t, 0] * e1x + tn[t, 1] * e1y + tn[t, 2] * e1z
            ny = tn[t, 0] * e2x + tn[t, 1] * e2y + tn[t, 2] * e2z
            nz = tn[t, 0] * ex + tn[t, 1] * ey + tn[t, 2] * ez
            up = min(_quick_upper(T, cn, cc, nc, solid, rp, rmax, hlo, hhi),
                     _plane_upper(T, nx, ny, nz, Pc, mc, rp))
            if up <= best:
                continue
            _upper(T, cn, cc, nc, solid, rp, rmax, hlo, hhi, bnd[nkeep])
            bnd[nkeep, 0] = min(bnd[nkeep, 0], up)
            if bnd[nkeep, 0] <= best:
                continue
            for v in range(3):
                bnd[nkeep, 6 + 3 * v] = T[v, 0]
                bnd[nkeep, 7 + 3 * v] = T[v, 1]
                bnd[nkeep, 8 + 3 * v] = T[v, 2]
            order[nkeep] = t
            nkeep += 1
        stats[i, 1] += nkeep
        # best first by upper bound: select the largest left (few are examined)
        nleft = nkeep
        while nleft > 0:
            jb = 0
            ub = bnd[0, 0]
            for j in range(1, nleft):
                if bnd[j, 0] > ub:
                    ub, jb = bnd[j, 0], j
            if ub <= best + EPS_T:
                break
            t = order[jb]
            for c in range(NBOUND):
                bq[c] = bnd[jb, c]
            nleft -= 1
            if jb != nleft:
                order[jb] = order[nleft]
                for c in range(NBOUND):
                    bnd[jb, c] = bnd[nleft, c]
            for v in range(3):
                T[v, 0], T[v, 1], T[v, 2] = bq[6 + 3 * v], bq[7 + 3 * v], bq[8 + 3 * v]
            _lower(T, Pc, mc, cn, cc, nc, solid, rp, bq)
            if bq[1] > best:
                best = bq[1]
                best_tri = tid[t]
                best_piece = kind[p]
                bx, by, bz = (px + bq[3] * e1x + bq[4] * e2x + bq[5] * ex,
                              py + bq[3] * e1y + bq[4] * e2y + bq[5] * ey,
                              pz + bq[3] * e1z + bq[4] * e2z + bq[5] * ez)
            if ub <= best + SLICE_EPS:
                continue
            stats[i, 2] += 1
            if method == 0:
                val = _exact_slice(T, Pc, mc, cn, cc, nc, solid, rp, best, ev, br, wit)
            else:
                val = _exact(T, Pc, mc, cn, cc, nc, solid, rp, best, bq, W, A, lam, res,
                             buf_a, buf_b, wit)
            if val > best:
                best = val
                best_tri = tid[t]
                best_piece = kind[p]
                bx, by, bz = (px + wit[0] * e1x + wit[1] * e2x + wit[2] * ex,
                              py + wit[0] * e1y + wit[1] * e2y + wit[2] * ey,
                              pz + wit[0] * e1z + wit[1] * e2z + wit[2] * ez)
    out_d[i] = best
    out_piece[i] = best_piece if best > 0.0 else -1
    out_tri[i] = best_tri
    out_pt[i, 0], out_pt[i, 1], out_pt[i, 2] = bx, by, bz
    return cand, bnd, order


@nb.njit(cache=True)
def _piece_scratch():
    """One thread's scratch for testing triangles against pieces: the BVH's traversal stack,
    the profile and its clipped copy, the sides (normals, offsets), GJK's simplex (W, A, lam,
    res) and the erosion's two buffers."""
    return (np.empty(STACK, dtype=np.int64), np.empty((_PV, 2)), np.empty((_PV, 2)),
            np.empty((_PV, 2)), np.empty(_PV), np.empty((4, 3)), np.empty((4, 3)), np.empty(12),
            np.empty(5), np.empty((_PV, 2)), np.empty((_PV, 2)))


@nb.njit(cache=True, parallel=True)
def _poses(node_lo, node_hi, node_left, node_right, node_start, node_count, tv, tn, tid, mlo,
           mhi, prof, nprof, rho, kind, tool_ptr, pose_tool, tips, axes, floor, reach, method,
           nchunks):
    n = tips.shape[0]
    out_d = np.empty(n)
    out_piece = np.empty(n, dtype=np.int64)
    out_tri = np.empty(n, dtype=np.int64)
    out_pt = np.empty((n, 3))
    stats = np.zeros((n, 3), dtype=np.int64)
    for c in nb.prange(nchunks):
        i0 = c * n // nchunks
        i1 = (c + 1) * n // nchunks
        cand = np.empty(256, dtype=np.int64)
        bnd = np.empty((256, NBOUND))
        order = np.empty(256, dtype=np.int64)
        stack, P, Pc, cn, cc, W, A, lam, res, buf_a, buf_b = _piece_scratch()
        T = np.empty((3, 3))
        wit = np.empty(3)
        bq = np.empty(NBOUND)
        ev = np.zeros(7)
        br = np.empty((NSTACK, NBR))
        for i in range(i0, i1):
            cand, bnd, order = _pose(
                i, node_lo, node_hi, node_left, node_right, node_start, node_count, tv, tn, tid,
                mlo, mhi, prof, nprof, rho, kind, tool_ptr, pose_tool, tips, axes, floor, reach,
                method, out_d, out_piece, out_tri, out_pt, stats, cand, bnd, order, stack, P, Pc,
                cn, cc, T, W, A, lam, res, buf_a, buf_b, wit, ev, br, bq)
    return out_d, out_piece, out_tri, out_pt, stats


def _arr(a, dtype) -> np.ndarray:
    """C-contiguous and writable (a read-only array would make numba compile the kernel once
    more for that type)."""
    return np.require(a, dtype=dtype, requirements=["C", "W"])


def _as_n3(a, name: str, n: int | None = None) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1 and a.shape == (3,) and n is not None:
        a = np.broadcast_to(a, (n, 3))
    a = _arr(a, np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {a.shape}")
    if n is not None and len(a) != n:
        raise ValueError(f"{name} must have {n} rows, got {len(a)}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite")
    return a


def _unit(axes: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(axes, axis=1)
    if (n <= 0.0).any():
        raise ValueError("axes must be non-zero")
    return _arr(axes / n[:, None], np.float64)


METHODS = {"slice": 0, "gjk": 1}


def _run(mesh_index: MeshIndex, prof, nprof, rho, kind, tool_ptr, pose_tool, tips, axes,
         floor: float, reach: float, method: str = "slice"):
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, found {method!r}")
    n = len(tips)
    nchunks = max(1, min(n, 8 * nb.get_num_threads(), (n + 63) // 64))
    return _poses(*mesh_index.arrays(), prof, nprof, rho, kind, tool_ptr, pose_tool, tips, axes,
                  float(floor), float(reach), METHODS[method], nchunks)


def pose_depths(mesh_index: MeshIndex, pieces: ToolPieces, tips: np.ndarray, axes: np.ndarray,
                *, reach: float, method: str = "slice") -> PoseDepths:
    """Signed penetration depth of the tool `pieces` into the mesh at N poses: `tips (N, 3)`
    (mm, part frame) and `axes (N, 3)` or `(3,)` (tip -> spindle, normalised here). `reach`
    (mm, >= 0): clearances are computed up to it; beyond, the depth is -reach. See
    `PoseDepths`. `method`: "slice" (default, the 1-D convex minimisation of `_exact_slice`) or
    "gjk" (GJK distance and bisection on the erosion depth: the same values, slower, and near
    a contact with a curved rim GJK may not certify a separation, then it keeps the upper end
    of its bracket: it may over-state a depth by up to ~1e-6 mm; for cross-checks)."""
    tips = _as_n3(tips, "tips")
    axes = _unit(_as_n3(axes, "axes", len(tips)))
    reach = float(reach)
    if not (reach >= 0.0 and math.isfinite(reach)):
        raise ValueError("reach must be a finite number >= 0")
    n = len(tips)
    if n == 0:
        return PoseDepths(np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64),
                          np.zeros((0, 3)))
    tool_ptr = np.array([0, len(pieces)], dtype=np.int64)
    pose_tool = np.zeros(n, dtype=np.int64)
    d, pc, tr, pt, _ = _run(mesh_index, _arr(pieces.prof, np.float64),
                            _arr(pieces.nprof, np.int64), _arr(pieces.rho, np.float64),
                            _arr(pieces.kind, np.int64), tool_ptr, pose_tool, tips, axes,
                            -reach, reach, method)
    return PoseDepths(d, pc, tr, pt)


# ---- allowable size --------------------------------------------------------------------------


def body_depths(mesh_index: MeshIndex, cutter, sizes: np.ndarray, tips: np.ndarray,
                axes: np.ndarray, *, floor: float) -> np.ndarray:
    """(N,) signed depth of the body of `cutter.with_size(sizes[i])` at pose i, values at or
    below `floor` (mm) reported as `floor` (only triangles beating it are examined)."""
    sizes = _arr(sizes, np.float64)
    prof, nprof, rho = body_profiles(cutter.cores(sizes), body_top(cutter))
    n = len(sizes)
    d, _, _, _, _ = _run(mesh_index, prof, nprof, _arr(rho, np.float64),
                         np.zeros(n, dtype=np.int64), np.arange(n + 1, dtype=np.int64),
                         np.arange(n, dtype=np.int64), _arr(tips, np.float64),
                         _arr(axes, np.float64), float(floor), max(0.0, -float(floor)))
    return d


def allowable_on_mesh(mesh_index: MeshIndex, cutter, cc: np.ndarray, normals: np.ndarray,
                      axes: np.ndarray, *, tol: float, s_max: float,
                      s_tol: float = 1e-6) -> np.ndarray:
    """(N,) the largest size s in [0, s_max] (mm; the cutter's allowable variable, `cutter.size`)
    such that the body of `cutter.with_size(s)` touching `cc (N, 3)` with unit normal
    `normals (N, 3)` at axis `axes (N, 3)` or `(3,)` (part frame) penetrates the mesh by at most
    `tol` mm (use tol > 0: the contact itself is a depth of 0 up to rounding); inf where s_max
    is still safe, 0 where even s = 0 is not. All rows bisect together to `s_tol` mm; the value
    returned is safe. Where the depth is not monotone in s, one transition is found."""
    cc = _as_n3(cc, "cc")
    n = len(cc)
    normals = _as_n3(normals, "normals", n)
    normals = normals / np.linalg.norm(normals, axis=1)[:, None]
    axes = _unit(_as_n3(axes, "axes", n))
    tol, s_max = float(tol), float(s_max)
    if not (s_max > 0.0 and math.isfinite(s_max)):
        raise ValueError("s_max must be a finite number > 0")
    if n == 0:
        return np.zeros(0)

    def unsafe(s: np.ndarray) -> np.ndarray:
        tips = cutter.tip_from_contact(cc, normals, axes, sizes=s)
        return body_depths(mesh_index, cutter, s, tips, axes, floor=tol) > tol

    lo = np.zeros(n)
    hi = np.full(n, s_max)
    top_safe = ~unsafe(hi)
    zero_bad = unsafe(lo)
    while float(np.max(hi - lo)) > s_tol:
        mid = 0.5 * (lo + hi)
        u = unsafe(mid)
        hi = np.where(u, mid, hi)
        lo = np.where(u, lo, mid)
    return np.where(top_safe, np.inf, np.where(zero_bad, 0.0, lo))
