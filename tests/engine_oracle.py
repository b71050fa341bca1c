"""An independent brute-force oracle for the allowable size: dense sampling of the part and, per
(CC point, test point) pair, bisection on "does the cutter of size s, placed touching the CC
point, contain the test point?". Written from the cutter's geometry alone (tip, axis, profile
radius by height), without the closed forms or `checker.kernels`. 3-axis (axis +z), psi = 0."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from checker.geometry.evaluate import evaluate
from checker.part import Part


@nb.njit(cache=True)
def _inside(s, ball, r, theta, cc, n, p):
    """True when p lies strictly inside the size-s cutter touching cc with normal n (tool axis
    +z, normal not vertical or the axis through the fillet centre for a vertical normal)."""
    nh = math.hypot(n[0], n[1])
    ex, ey = (n[0] / nh, n[1] / nh) if nh > 1e-9 else (0.0, 0.0)
    if ball:
        cx, cy, cz = cc[0] + s * n[0], cc[1] + s * n[1], cc[2] + s * n[2]
        y = p[2] - cz  # height above the sphere centre
        rho = math.hypot(p[0] - cx, p[1] - cy)
        if y <= -s * math.sin(theta):
            if abs(y) >= s:
                return False
            return rho < math.sqrt(s * s - y * y) - 1e-12
        return rho < s / math.cos(theta) + y * math.tan(theta) - 1e-12
    ox, oy, oz = cc[0] + r * n[0], cc[1] + r * n[1], cc[2] + r * n[2]
    y = p[2] - oz  # height above the corner centres
    if nh > 1e-9:
        rho = math.hypot(p[0] - ox - s * ex, p[1] - oy - s * ey)
    else:  # vertical normal: e is free, some direction e puts the axis nearest to p
        rho = abs(math.hypot(p[0] - ox, p[1] - oy) - s)
    if y <= -r:  # on or below the bottom plane: touched at most, not cut
        return False
    if y < 0.0:
        return rho < s + math.sqrt(r * r - y * y) - 1e-12
    return rho < s + r - 1e-12


@nb.njit(cache=True)
def _size(ball, r, theta, c, nn, p, s_hi):
    """Smallest s with p inside the size-s cutter (bisection), inf if not inside at s_hi."""
    if not _inside(s_hi, ball, r, theta, c, nn, p):
        return np.inf
    lo, hi = 0.0, s_hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _inside(mid, ball, r, theta, c, nn, p):
            hi = mid
        else:
            lo = mid
    return hi


@nb.njit(cache=True, parallel=True)
def _row_min(ball, r, theta, cc, n, pts, s_max, best, arg):
    """Per row the minimum size over all points: a point outside the cutter of the best size
    so far cannot lower it (the cutters are nested in s), else it is bisected."""
    for i in nb.prange(cc.shape[0]):
        b, a = s_max, -1
        for j in range(pts.shape[0]):
            d = pts[j] - cc[i]
            if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < 1e-6:
                continue
            if _inside(b, ball, r, theta, cc[i], n[i], pts[j]):
                s = _size(ball, r, theta, cc[i], n[i], pts[j], b)
                if s < b:
                    b, a = s, j
        best[i] = b if a >= 0 else np.inf
        arg[i] = a


def dense_points(part: Part, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n x n uniform (u, v) grid on every surface: points (K, 3), surface ids, uv (K, 2)."""
    P, S, UV = [], [], []
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        U, V = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n), indexing="ij")
        u, v = U.ravel(), V.ravel()
        if s.trim is not None:
            keep = np.asarray(s.trim.contains(u, v), dtype=bool)
            u, v = u[keep], v[keep]
        P.append(evaluate(s, u, v).points)
        S.append(np.full(u.size, s.id))
        UV.append(np.column_stack([u, v]))
    return np.concatenate(P), np.concatenate(S), np.concatenate(UV)


def height_grids(part: Part, dense: int) -> list:
    """Per surface (surface, U, V, height) on a dense (u, v) grid."""
    out = []
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        g = np.linspace(0.0, 1.0, dense)
        U, V = np.meshgrid(u0 + g * (u1 - u0), v0 + g * (v1 - v0), indexing="ij")
        out.append((s, U, V, evaluate(s, U.ravel(), V.ravel()).points[:, 2].reshape(U.shape)))
    return out


def contour_points(grids: list, z: float):
    """Points of every surface at height z (the bottom plane of a flat-bottomed cutter, where
    the size jumps to inf): sign changes of the height along the lines of the dense grids,
    refined by regula falsi, the end on the upper side kept: points (K, 3), surface ids,
    uv (K, 2)."""
    out, sids, uvs = [], [], []
    for s, U, V, h0 in grids:
        h = h0 - z
        for axis in (0, 1):
            a = (slice(None, -1), slice(None)) if axis == 0 else (slice(None), slice(None, -1))
            b = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
            i = np.nonzero((h[a] > 0) != (h[b] > 0))
            if not i[0].size:
                continue
            ua, va, ha = U[a][i], V[a][i], h[a][i]
            ub, vb, hb = U[b][i], V[b][i], h[b][i]
            for _ in range(4):  # secant / regula falsi on the segment
                t = ha / (ha - hb)
                um, vm = ua + t * (ub - ua), va + t * (vb - va)
                hm = evaluate(s, um, vm).points[:, 2] - z
                left = (hm > 0) == (ha > 0)
                ua, va, ha = np.where(left, um, ua), np.where(left, vm, va), np.where(left, hm, ha)
                ub, vb, hb = np.where(left, ub, um), np.where(left, vb, vm), np.where(left, hb, hm)
            pick = np.where(ha > 0, 0, 1)  # keep the end on the upper side (cut side)
            uu, vv = np.where(pick == 0, ua, ub), np.where(pick == 0, va, vb)
            if s.trim is not None:
                keep = np.asarray(s.trim.contains(uu, vv), dtype=bool)
                uu, vv = uu[keep], vv[keep]
            out.append(evaluate(s, uu, vv).points)
            sids.append(np.full(uu.size, s.id))
            uvs.append(np.column_stack([uu, vv]))
    if not out:
        return np.zeros((0, 3)), np.zeros(0, int), np.zeros((0, 2))
    return np.concatenate(out), np.concatenate(sids), np.concatenate(uvs)


@nb.njit(cache=True)
def _near_best(ball, r, theta, c, nn, pts, s):
    """Mask of the points inside the size-s cutter (their size is below s)."""
    out = np.zeros(pts.shape[0], dtype=np.bool_)
    for j in range(pts.shape[0]):
        d = pts[j] - c
        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] >= 1e-6:
            out[j] = _inside(s, ball, r, theta, c, nn, pts[j])
    return out


def _zoom(s, uv0, dense: int, ball, r, th, c, nn, s_max) -> float:
    """Smallest size on two zoomed grids around uv0 on surface s (41 x 41 over +-1 dense cell,
    then over +-1/10 cell around that grid's best)."""
    (u0, u1), (v0, v1) = s.domain
    du, dv = (u1 - u0) / (dense - 1), (v1 - v0) / (dense - 1)
    best, centre = np.inf, np.asarray(uv0, dtype=float)
    for span in (1.0, 0.1):
        g = np.linspace(-span, span, 41)
        U, V = np.meshgrid(np.clip(centre[0] + g * du, u0, u1),
                           np.clip(centre[1] + g * dv, v0, v1), indexing="ij")
        u, v = U.ravel(), V.ravel()
        if s.trim is not None:
            keep = np.asarray(s.trim.contains(u, v), dtype=bool)
            u, v = u[keep], v[keep]
        if not u.size:
            break
        lp = evaluate(s, u, v).points
        lb, la = np.empty(1), np.empty(1, dtype=np.int64)
        _row_min(ball, r, th, c[None], nn[None], lp, s_max, lb, la)
        if la[0] < 0:
            break
        best = min(best, lb[0])
        centre = np.array([u[la[0]], v[la[0]]])
    return best


def oracle_sizes(part: Part, cutter, cc: np.ndarray, n: np.ndarray, dense: int,
                 s_max: float = 1000.0, cc_surface=None, cc_uv=None) -> np.ndarray:
    """Allowable size per CC row: bisection over every dense point (and, for flat-bottomed
    cutters, over the contour at the bottom plane), then zoomed local grids (see the loop)."""
    ball = cutter.kind in ("ball", "tapered_ball")
    r, th = float(cutter.r), float(cutter.theta)
    pts, sid, uv = dense_points(part, dense)
    m = len(cc)
    best, k = np.empty(m), np.empty(m, dtype=np.int64)
    _row_min(ball, r, th, cc, n, pts, s_max, best, k)
    if not ball:  # flat bottom: the minimum often lies on the contour at the bottom plane
        grids = height_grids(part, dense)
        for i in range(m):
            zb = cc[i, 2] + r * n[i, 2] - r + 1e-9
            cp, cs, cuv = contour_points(grids, zb)
            if not len(cp):
                continue
            vals = np.array([_size(ball, r, th, cc[i], n[i], p, s_max) for p in cp])
            best[i] = min(best[i], vals.min())
            # fine contour grids around the best three contour points (1 mm apart) and around
            # the CC point on every surface that passes within 3 mm of it (seams)
            centres: list[tuple[int, np.ndarray, np.ndarray]] = []
            for j in np.argsort(vals)[:50]:
                if np.isfinite(vals[j]) and all(np.linalg.norm(cp[j] - c3) > 1.0
                                                for _, _, c3 in centres):
                    centres.append((int(cs[j]), cuv[j], cp[j]))
                if len(centres) == 3:
                    break
            d = np.linalg.norm(pts - cc[i], axis=1)
            for sidx in np.unique(sid[d < 3.0]):
                j = np.flatnonzero(sid == sidx)[np.argmin(d[sid == sidx])]
                centres.append((int(sidx), uv[j], pts[j]))
            for sidx, uv0, _ in centres:
                s = part.surfaces[sidx]
                (u0, u1), (v0, v1) = s.domain
                g = np.linspace(-2.0, 2.0, 81) / (dense - 1)
                U, V = np.meshgrid(np.clip(uv0[0] + g * (u1 - u0), u0, u1),
                                   np.clip(uv0[1] + g * (v1 - v0), v0, v1), indexing="ij")
                h = evaluate(s, U.ravel(), V.ravel()).points[:, 2].reshape(U.shape)
                fp = contour_points([(s, U, V, h)], zb)[0]
                if len(fp):
                    lb, la = np.empty(1), np.empty(1, dtype=np.int64)
                    _row_min(ball, r, th, cc[i:i + 1], n[i:i + 1], fp, s_max, lb, la)
                    best[i] = min(best[i], lb[0])
    # local densification: zoomed grids around the best few dense points of each row (distinct
    # places within 5 % of the best) and around the CC point on its own surface
    out = best.copy()
    for i in range(m):
        centres = []
        if np.isfinite(best[i]):
            near = np.flatnonzero(_near_best(ball, r, th, cc[i], n[i], pts, best[i] * 1.05 + 0.05))
            vals = np.array([_size(ball, r, th, cc[i], n[i], pts[j], s_max) for j in near])
            for j in near[np.argsort(vals)]:
                if all(np.linalg.norm(pts[j] - pts[q]) > 1.0 for q, _ in centres):
                    centres.append((j, None))
                if len(centres) == 2:
                    break
        starts = [(int(sid[j]), uv[j]) for j, _ in centres]
        if cc_surface is not None and cc_surface[i] >= 0:
            starts.append((int(cc_surface[i]), cc_uv[i]))
        for sidx, uv0 in starts:
            out[i] = min(out[i], _zoom(part.surfaces[sidx], uv0, dense, ball, r, th, cc[i], n[i],
                                       s_max))
    return out
