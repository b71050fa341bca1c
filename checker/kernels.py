"""Numba kernels: the size of the imaginary cutter through a test point (docs/MATH.md §3).

All inputs are float64 arrays in the TOOL frame (tool axis +z, mm). For a pair (test point P,
CC point Pcc with unit normal n out of the material) the kernels return the size, in the family's
allowable variable, of the imaginary cutter that touches Pcc with normal n and passes through P:
R (axis -> corner centre) for the APT family (flat, bull-nose, general APT), r for the ball family
(ball, tapered ball). Limits by rule, never NaN: 0 when P is inside the size-0 cutter or the CC
point cannot be touched tangentially (n_z <= 0 or n_z < sin(theta)), inf when no cutter of the
family reaches P (on or below the tangent plane, beyond the R -> inf limiting surface, denominator
<= 0). "On" the tangent plane is within PLANE_SLOPE |q| of it: there the sign of n.q is the
coordinates' rounding (a flat face through Pcc), which must not decide a size (docs/MATH.md §3.2).

`tol` (mm, >= 0) is a depth tolerance: P counts as cut only when it lies at least `tol` inside the
cutter (the profile offset inward by `tol`). `tol = 0` is the exact model (docs/MATH.md §3.6).

Contact cases (`contact_case`, the one place they are decided, with the one slack NZ_SLACK;
`Cutter.contact_case` asks it for many rows, docs/MATH.md §2):
- untouchable (n_z <= 0 or n_z < sin(theta) - NZ_SLACK): every size is 0;
- fillet contact (sin(theta) - NZ_SLACK <= n_z <= cos(psi), every n_z > 0 when psi = 0):
  fillet centre O = Pcc + r n, axis through O + R e, closed form R = (|d|^2 - k^2) /
  (2 (e.d + k)) with k from the band of dz (docs/MATH.md §3.1, §3.2);
- tip contact (psi > 0 and n_z > cos(psi), e.g. a drill on a floor): the cone vertex touches Pcc,
  the axis passes through Pcc, R is the smallest size whose solid contains P (§3.3);
- vertical normal (|n_xy| < EPS_H) with psi = 0: e is taken from the caller's `e`; without it the
  worst case over all directions e is returned, R = (|d| - k) / 2 (§3.4).
Ball family: docs/MATH.md §3.5; the thesis's errata the kernels correct: §4.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

EPS_H = 1e-9  # |n_xy| below this: the normal is vertical, e is not defined by the surface
NZ_SLACK = 1e-9  # n_z this far below sin(theta) still touches (a wall parallel to the taper)
_ROUNDING_MM = 1e-9  # mm: bounds this near a decision leave it to the exact kernel
PLANE_SLOPE = 1e-8  # P within this slope of the tangent plane at Pcc (|n.q| <= it |q|) lies on it
_PLANE_SLOPE2 = PLANE_SLOPE * PLANE_SLOPE
INF = np.inf

FAMILY_APT = 0  # R variable: flat, bull-nose, general APT
FAMILY_BALL = 1  # r variable: ball, tapered ball

# contact cases (`contact_case`)
UNTOUCHABLE = 0  # no cutter of the family touches Pcc tangentially: every size is 0
FILLET = 1  # the corner arc (or, r = 0, the bottom edge) touches Pcc
TIP = 2  # the cone's vertex touches Pcc (psi > 0, n_z > cos(psi))

# layout of the parameter vector built by `params`
_R, _RP, _TOL, _SIN_T, _COS_T, _TAN_T, _SEC_T = 0, 1, 2, 3, 4, 5, 6
_SIN_P, _COS_P, _TAN_P, _COT_P, _CSC_P, _SEC_P, _FLAT = 7, 8, 9, 10, 11, 12, 13


def params(r: float, psi: float, theta: float, tol: float = 0.0) -> np.ndarray:
    """Constant vector for the kernels: corner radius `r` (mm; ignored by the ball family, whose
    r is the variable), bottom cone angle `psi` and taper angle `theta` (rad), depth tolerance
    `tol` (mm)."""
    flat = psi == 0.0
    out = np.zeros(14)
    out[_R] = r
    out[_RP] = r - tol
    out[_TOL] = tol
    out[_SIN_T], out[_COS_T] = math.sin(theta), math.cos(theta)
    out[_TAN_T], out[_SEC_T] = math.tan(theta), 1.0 / math.cos(theta)
    out[_SIN_P], out[_COS_P] = math.sin(psi), math.cos(psi)
    out[_TAN_P], out[_SEC_P] = math.tan(psi), 1.0 / math.cos(psi)
    out[_COT_P] = 0.0 if flat else 1.0 / math.tan(psi)
    out[_CSC_P] = 0.0 if flat else 1.0 / math.sin(psi)
    out[_FLAT] = 1.0 if flat else 0.0
    return out


@njit(cache=True)
def _k_band(dz, prm):
    """Profile radius minus R at height dz above the fillet centre (shrunk corner r - tol);
    -inf below a flat bottom (nothing of the cutter there)."""
    rp = prm[_RP]
    flat = prm[_FLAT] > 0.5
    if rp > 0.0:
        if dz >= -rp * prm[_SIN_T]:
            return dz * prm[_TAN_T] + rp * prm[_SEC_T]
        if dz > -rp * prm[_COS_P]:
            return math.sqrt(rp * rp - dz * dz)
        if flat:
            return -INF
        return dz * prm[_COT_P] + rp * prm[_CSC_P]
    # corner radius shrunk below zero: the inward offset of a sharp corner, min of the two lines
    k = dz * prm[_TAN_T] + rp * prm[_SEC_T]
    if flat:
        if dz <= -rp:
            return -INF
        return k
    kc = dz * prm[_COT_P] + rp * prm[_CSC_P]
    return kc if kc < k else k


@njit(cache=True)
def _apt_tip_contact(qx, qy, qz, prm):
    """R for tip contact (psi > 0, n_z > cos(psi)): tip at Pcc, axis through Pcc. q = P - Pcc."""
    rho = math.sqrt(qx * qx + qy * qy)
    tol = prm[_TOL]
    rinf = qz * prm[_COT_P] - tol * prm[_CSC_P]  # radius of the R -> inf cutter at this height
    if rho >= rinf:
        return INF
    t = prm[_TAN_P]
    rp = prm[_RP]
    c = qz - prm[_R] * prm[_SEC_P]  # height above the fillet centre of the size-0 cutter
    if _k_band(c, prm) > rho:
        return 0.0
    slope = 1.0 - t * prm[_TAN_T]
    r_taper = (rho - c * prm[_TAN_T] - rp * prm[_SEC_T]) / slope
    if rp <= 0.0:
        return max(r_taper, 0.0)
    r1 = (c + rp * prm[_SIN_T]) / t  # size where P crosses from the taper to the fillet band
    r2 = (c + rp * prm[_COS_P]) / t  # size where P crosses from the fillet to the cone band
    if r1 > 0.0 and r1 + _k_band(c - r1 * t, prm) > rho:
        return min(max(r_taper, 0.0), r1)
    # fillet band: |P - O(R)| = rp with O(R) = (R, R t + r sec(psi)); entering root
    a = 1.0 + t * t
    q = rho + c * t
    cq = rho * rho + c * c - rp * rp
    disc = q * q - a * cq
    s = math.sqrt(disc) if disc > 0.0 else 0.0
    root = cq / (q + s) if q > 0.0 else (q - s) / a
    lo = r1 if r1 > 0.0 else 0.0
    return max(min(max(root, lo), r2), 0.0)


@njit(cache=True, forceinline=True)
def _axis_dir(nx, ny, ex, ey, has_e):
    """Unit horizontal e (fillet centre -> axis) from n, else from the caller's e; (0, 0, True)
    when neither defines it (worst case over directions)."""
    nh = math.sqrt(nx * nx + ny * ny)
    if nh > EPS_H:
        return nx / nh, ny / nh, False
    eh = math.sqrt(ex * ex + ey * ey) if has_e else 0.0
    if eh > EPS_H:
        return ex / eh, ey / eh, False
    return 0.0, 0.0, True


@njit(cache=True, forceinline=True)
def _fillet_size(dx, dy, dz, ux, uy, worst, prm):
    """R for fillet contact: (dx, dy, dz) = P - O with O = Pcc + r n, e = (ux, uy)."""
    k = _k_band(dz, prm)
    if k == -INF:
        return INF
    dd = dx * dx + dy * dy
    if k >= 0.0 and dd <= k * k:
        return 0.0
    if worst:
        dn = math.sqrt(dd)  # worst case over e: e along d, R = (|d| - k) / 2
        if dn + k <= 0.0:
            return INF
        return max(0.5 * (dn - k), 0.0)
    den = ux * dx + uy * dy + k
    if den <= 0.0:
        return INF
    return max((dd - k * k) / (2.0 * den), 0.0)


@njit(cache=True, forceinline=True)
def contact_case(nz, prm):
    """The contact case of a CC point with tool-frame unit normal z-component `nz` for the
    family of `prm` (module docstring): UNTOUCHABLE below the taper (n_z <= 0 or n_z <
    sin(theta) - NZ_SLACK), TIP above the cone (psi > 0 and n_z > cos(psi): at n_z = cos(psi)
    the cone's side lies in the tangent plane and the fillet case is kept), FILLET between.
    psi + theta < 90 degrees, so the two bounds never cross."""
    if nz <= 0.0 or nz < prm[_SIN_T] - NZ_SLACK:
        return UNTOUCHABLE
    if prm[_FLAT] < 0.5 and nz > prm[_COS_P]:
        return TIP
    return FILLET


@njit(cache=True)
def contact_cases(nz, prm):
    """(N,) int8 `contact_case` of each n_z of `nz (N,)`: the cutter's rows ask this."""
    out = np.empty(nz.shape[0], dtype=np.int8)
    for i in range(nz.shape[0]):
        out[i] = contact_case(nz[i], prm)
    return out


@njit(cache=True, forceinline=True)
def _not_above(nq, qx, qy, qz, tol):
    """Whether P = Pcc + q is not above the tangent plane at Pcc (offset by the depth tolerance
    `tol`; `nq` = n.q): n.q <= tol, or within PLANE_SLOPE |q| of it, where the sign of n.q is
    rounding's (a point of a flat face through Pcc). The convex cutter never reaches it."""
    h = nq - tol
    return h <= 0.0 or h * h <= _PLANE_SLOPE2 * (qx * qx + qy * qy + qz * qz)


@njit(cache=True, forceinline=True)
def apt_size(qx, qy, qz, nx, ny, nz, ex, ey, has_e, prm):
    """R of the imaginary APT-family cutter through P = Pcc + q, touching Pcc with normal n."""
    case = contact_case(nz, prm)
    if case == UNTOUCHABLE:
        return 0.0
    if _not_above(qx * nx + qy * ny + qz * nz, qx, qy, qz, prm[_TOL]):
        return INF  # on or below the tangent plane: the convex cutter never reaches P
    if case == TIP:
        return _apt_tip_contact(qx, qy, qz, prm)
    r = prm[_R]
    ux, uy, worst = _axis_dir(nx, ny, ex, ey, has_e)
    return _fillet_size(qx - r * nx, qy - r * ny, qz - r * nz, ux, uy, worst, prm)


class PlaneDisc(NamedTuple):
    """What `plane_disc_bound` needs of one CC row, from `plane_disc`: `usable` (False where
    `apt_size` can be 0 at every point, n_z too small), the fillet centre's horizontal position
    (ox, oy) relative to Pcc, the axis direction (ux, uy) (`worst`: none, worst case over
    directions) and the band k at the plane's height."""

    usable: bool
    ox: float
    oy: float
    ux: float
    uy: float
    worst: bool
    k: float


@njit(cache=True)
def plane_disc(qz, nx, ny, nz, ex, ey, prm):
    """The `PlaneDisc` of a flat-bottomed APT-family cutter (psi = 0) touching Pcc with normal
    n, for points at height qz above Pcc (`apt_size` with has_e True)."""
    usable = prm[_FLAT] > 0.5 and contact_case(nz, prm) == FILLET
    r = prm[_R]
    ux, uy, worst = _axis_dir(nx, ny, ex, ey, True)
    return PlaneDisc(usable, r * nx, r * ny, ux, uy, worst, _k_band(qz - r * nz, prm))


@njit(cache=True, forceinline=True)
def plane_disc_bound(pd, qx, qy, rho):
    """A lower bound (mm; -inf: none) of `apt_size` over the points at the height of `pd`
    (`plane_disc`) within rho mm horizontally of q = (qx, qy) (relative to Pcc): with
    d = q - O, |d| >= D - rho and e.d + k <= e.d_q + rho + k, so R = (|d|^2 - k^2) /
    (2 (e.d + k)) >= ((D - rho)^2 - k^2) / (2 (e.d_q + rho + k)), inf where that denominator
    bound is < 0 (R = inf throughout); (|d| - k) / 2 for the worst case over directions."""
    if not pd.usable or pd.k == -INF:
        return -INF
    dx, dy = qx - pd.ox, qy - pd.oy
    near = max(math.sqrt(dx * dx + dy * dy) - rho, 0.0)
    if pd.worst:
        return 0.5 * (near - pd.k)
    den = pd.ux * dx + pd.uy * dy + rho + pd.k
    if den <= _ROUNDING_MM:  # R = inf throughout, unless rounding could decide
        return INF if den < -_ROUNDING_MM else -INF
    return (near * near - pd.k * pd.k) / (2.0 * den)


@njit(cache=True)
def ball_size(qx, qy, qz, nx, ny, nz, prm):
    """r of the imaginary (tapered) ball end-mill through P = Pcc + q touching Pcc with normal n;
    sphere centre Pcc + r n, taper angle theta above the sphere (theta = 0: cylinder)."""
    sin_t = prm[_SIN_T]
    tol = prm[_TOL]
    if contact_case(nz, prm) == UNTOUCHABLE:
        return 0.0
    nq = qx * nx + qy * ny + qz * nz
    if _not_above(nq, qx, qy, qz, tol):
        return INF
    qh2 = qx * qx + qy * qy
    den = nz - sin_t
    num = qz - tol * sin_t
    if den > NZ_SLACK:  # n_z above sin(theta): the sphere/taper boundary is at a finite size
        rref = num / den  # size at which P's height is the sphere/taper boundary
    elif num > 0.0:
        rref = INF
    else:
        rref = -INF
    if rref > 0.0:
        a = prm[_SEC_T] - nz * prm[_TAN_T]
        b = qz * prm[_TAN_T] - tol * prm[_SEC_T]
        if b > 0.0 and qh2 < b * b:
            return 0.0  # inside the tip cone: every cutter of the family gouges P
        e1 = (den / prm[_COS_T]) ** 2
        e2 = 2.0 * (nx * qx + ny * qy + a * b)
        e3 = b * b - qh2
        if rref == INF:
            inside = e2 > 0.0 or (e2 == 0.0 and e3 > 0.0)
        else:
            inside = (e1 * rref + e2) * rref + e3 > 0.0 and a * rref + b > 0.0
        if inside:
            disc = e2 * e2 - 4.0 * e1 * e3
            s = math.sqrt(disc) if disc > 0.0 else 0.0
            if e2 + s > 0.0:
                root = -2.0 * e3 / (e2 + s)
            elif e1 > 0.0:
                root = (s - e2) / (2.0 * e1)
            else:
                root = rref
            return min(max(root, 0.0), rref)
    rs = (qx * qx + qy * qy + qz * qz - tol * tol) / (2.0 * (nq - tol))
    return max(rs, rref, 0.0)


@njit(cache=True)
def _one(p, cc, n, e, has_e, family, prm, i):
    """Size of pair i: test point p[i] against CC point cc[i] (normal n[i], direction e[i])."""
    qx = p[i, 0] - cc[i, 0]
    qy = p[i, 1] - cc[i, 1]
    qz = p[i, 2] - cc[i, 2]
    if family == FAMILY_BALL:
        return ball_size(qx, qy, qz, n[i, 0], n[i, 1], n[i, 2], prm)
    ex = e[i, 0] if has_e else 0.0
    ey = e[i, 1] if has_e else 0.0
    return apt_size(qx, qy, qz, n[i, 0], n[i, 1], n[i, 2], ex, ey, has_e, prm)


PARALLEL_MIN = 20_000  # below this many pairs the serial kernels win (no thread start-up)


@njit(cache=True, parallel=True)
def _pair_sizes_par(p, cc, n, e, has_e, family, prm):
    out = np.empty(p.shape[0])
    for i in prange(p.shape[0]):
        out[i] = _one(p, cc, n, e, has_e, family, prm, i)
    return out


@njit(cache=True)
def _pair_sizes_ser(p, cc, n, e, has_e, family, prm):
    out = np.empty(p.shape[0])
    for i in range(p.shape[0]):
        out[i] = _one(p, cc, n, e, has_e, family, prm, i)
    return out


def pair_sizes(p, cc, n, e, has_e, family, prm):
    """(K,) sizes for K pairs (p[i], cc[i], n[i], e[i]); all (K,3) tool-frame arrays, mm."""
    if p.shape[0] >= PARALLEL_MIN:
        return _pair_sizes_par(p, cc, n, e, has_e, family, prm)
    return _pair_sizes_ser(p, cc, n, e, has_e, family, prm)
