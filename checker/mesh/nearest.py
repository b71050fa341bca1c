"""Weights of the point of a simplex (segment, triangle, tetrahedron; 3-D, mm) nearest the
origin, after Ericson (2005, Real-Time Collision Detection, 5.1.5): the sub-steps of GJK
(`checker.mesh.gjk`) and of a triangle's point nearest the tool's axis
(`checker.mesh.bounds`)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True)
def segment_weights(ax, ay, az, bx, by, bz):
    """Weights (u, v) of the point of segment ab nearest the origin."""
    ex, ey, ez = bx - ax, by - ay, bz - az
    d = ex * ex + ey * ey + ez * ez
    if d <= 0.0:
        return 1.0, 0.0
    s = -(ax * ex + ay * ey + az * ez) / d
    s = min(1.0, max(0.0, s))
    return 1.0 - s, s


@nb.njit(cache=True)
def triangle_weights(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Weights (u, v, w) of the point of triangle abc nearest the origin (Ericson, Real-Time
    Collision Detection 5.1.5), falling back to the edges for a (nearly) degenerate triangle."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    ab2 = abx * abx + aby * aby + abz * abz
    ac2 = acx * acx + acy * acy + acz * acz
    abac = abx * acx + aby * acy + abz * acz
    if ab2 * ac2 - abac * abac <= 1e-20 * ab2 * ac2 or ab2 == 0.0 or ac2 == 0.0:
        return edge_weights(ax, ay, az, bx, by, bz, cx, cy, cz)
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
    return edge_weights(ax, ay, az, bx, by, bz, cx, cy, cz)


@nb.njit(cache=True)
def edge_weights(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Weights of the point nearest the origin on the edges of a degenerate triangle."""
    u1, v1 = segment_weights(ax, ay, az, bx, by, bz)
    p1 = (u1 * ax + v1 * bx) ** 2 + (u1 * ay + v1 * by) ** 2 + (u1 * az + v1 * bz) ** 2
    u2, w2 = segment_weights(ax, ay, az, cx, cy, cz)
    p2 = (u2 * ax + w2 * cx) ** 2 + (u2 * ay + w2 * cy) ** 2 + (u2 * az + w2 * cz) ** 2
    v3, w3 = segment_weights(bx, by, bz, cx, cy, cz)
    p3 = (v3 * bx + w3 * cx) ** 2 + (v3 * by + w3 * cy) ** 2 + (v3 * bz + w3 * cz) ** 2
    if p1 <= p2 and p1 <= p3:
        return u1, v1, 0.0
    if p2 <= p3:
        return u2, 0.0, w2
    return 0.0, v3, w3


@nb.njit(cache=True)
def tetrahedron_weights(W, lam):
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
            u, v, w = triangle_weights(W[i, 0], W[i, 1], W[i, 2], W[j, 0], W[j, 1], W[j, 2],
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
