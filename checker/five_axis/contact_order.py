"""Flat-end and bull-nose positioning by the order of contact (Liu et al. n.d.; docs/MATH.md §11).

Liu et al. (n.d.) put the cutter's circle in contact with the surface to the highest order: with
`Phi(theta) = F(circle(theta))` (seed eq. 3-4, `F = 0` the surface), `Phi' = Phi'' = Phi''' = 0`
at the contact (eqs. 5-7). Here the curve is the cutter's *effective* circle seen along the feed
(the bottom circle of radius `R` projected along the feed `f` onto the (`s`, `n`) plane: an
ellipse), and `F` the surface's normal section across the feed, `Z(x) = kappa x^2 / 2 +
kappa_s x^3 / 6 + ...` (`Z` along `n`, towards the tool; `x` along `s`; `kappa` the section's
curvature bending towards the tool, `kappa_s` its derivative, `checker.five_axis.curvature`).
For a bull-nose, the corner-centre circle of radius `R` against the parallel surface `r` mm out
(seed §5, Fig. 3; `LocalSurface.offset`).

The ellipse, for a unit axis `a = (beta, -sqrt(1 - beta^2) sin(omega),
sqrt(1 - beta^2) cos(omega))` in (f, s, n), has semi-axes `A = R` and `B = beta R` (`beta = a.f`),
its major axis `(cos(omega), sin(omega))` in the (s, n) plane; its lowest point (horizontal
tangent) is the contact. At the point where its outward normal makes the angle `t`
with the major axis, its radius of curvature is (§11.2)

    rho(t) = A^2 B^2 / D(t)^(3/2),   D(t) = A^2 cos^2 t + B^2 sin^2 t,     (E1)

and the contact is at `t = -pi/2 - omega`. Second order (seed eq. 6): the curvatures match,
`1 / rho = kappa`; at `omega = 0` this is `beta = sin(lead) = kappa R` (Meusnier: the circle's
normal curvature). Third order (seed eq. 7): `d(1/rho)/ds = kappa_s`, which with (E1) reads

    D^(3/2) = kappa A^2 B^2,   3 kappa^2 (B^2 - A^2) sin(omega) cos(omega) = kappa_s D   (E2)

(`D = A^2 sin^2 omega + B^2 cos^2 omega`), two equations in (`B`, `omega`): the lead and the
tilt. `omega ~ -kappa_s R^2 / (3 cos^2 lead)` for small `kappa_s`; a symmetric section
(`kappa_s = 0`) needs no tilt. Radians, mm, part frame."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from checker.five_axis.curvature import LocalSurface, local_surface
from checker.five_axis.lead_tilt import angles_from_axes, axes_from_angles, local_frames

_NEWTON = 40


class Contact(NamedTuple):
    """Per CC point (N,): `beta = a.f` (the sine of the axis's inclination out of the cross-feed
    plane), `omega` (rad, the turn of the ellipse in it) and `order` (int) of contact reached:
    3 (E2 solved), 2 (curvatures matched, no tilt solves the third order), 1 (the section does
    not bend towards the tool: `beta` the least lead's sine), 0 (it bends more than the circle
    can: `kappa R >= 1`, `beta` the greatest lead's sine)."""

    beta: np.ndarray
    omega: np.ndarray
    order: np.ndarray


def contact(kappa: np.ndarray, kappa_s: np.ndarray, R: float, *, min_lead: float,
            max_lead: float) -> Contact:
    """The highest-order contact of a circle of radius `R` (mm) seen along the feed with a
    section of curvature `kappa` (1/mm, towards the tool) and `kappa_s` (1/mm^2): (E2) by
    Newton's method from the second-order pose (`beta = kappa R`, `omega` its first-order
    estimate), all points together. `min_lead`, `max_lead` (rad) bound the lead."""
    k, ks = np.broadcast_arrays(np.asarray(kappa, float), np.asarray(kappa_s, float))
    lo, hi = math.sin(min_lead), math.sin(max_lead)
    beta = np.clip(k * R, lo, hi)
    order = np.where(k * R <= lo, 1, np.where(k * R >= hi, 0, 2))
    omega = np.zeros(k.shape)
    live = order == 2
    if live.any():
        b, w, ok = _third_order(k[live], ks[live], R)
        ok &= (b >= lo) & (b <= hi)
        beta[np.flatnonzero(live)[ok]] = b[ok]
        omega[np.flatnonzero(live)[ok]] = w[ok]
        order[np.flatnonzero(live)[ok]] = 3
    return Contact(beta, omega, order)


def _third_order(k: np.ndarray, ks: np.ndarray, R: float):
    """(beta, omega, converged) solving (E2) with `A = R`, `B = beta R`."""
    A2 = R * R
    B = k * A2
    w = -ks * A2 / (3.0 * (1.0 - (k * R) ** 2))
    for _ in range(_NEWTON):
        s, c = np.sin(w), np.cos(w)
        D = A2 * s * s + B * B * c * c
        DB, Dw = 2.0 * B * c * c, (A2 - B * B) * 2.0 * s * c
        sq = np.sqrt(np.maximum(D, 0.0))
        f1 = D * sq - k * A2 * B * B
        f2 = 3.0 * k * k * (B * B - A2) * s * c - ks * D
        j11, j12 = 1.5 * sq * DB - 2.0 * k * A2 * B, 1.5 * sq * Dw
        j21 = 6.0 * k * k * B * s * c - ks * DB
        j22 = 3.0 * k * k * (B * B - A2) * (c * c - s * s) - ks * Dw
        det = j11 * j22 - j12 * j21
        det = np.where(np.abs(det) > 0.0, det, np.inf)
        B = B - (f1 * j22 - f2 * j12) / det
        w = w - (j11 * f2 - j21 * f1) / det
    s, c = np.sin(w), np.cos(w)
    D = A2 * s * s + B * B * c * c
    ok = (np.abs(ellipse_curvature(R, B / R, w)[0] - k) <= 1e-9 * np.maximum(k, 1e-9) + 1e-12) & \
        (np.abs(w) < 0.5 * math.pi) & (B > 0.0) & (B < R) & (D > 0.0)
    ok &= np.abs(ellipse_curvature(R, B / R, w)[1] - ks) <= 1e-7 * (np.abs(ks) + k / R)
    return B / R, w, ok


def ellipse_curvature(R: float, beta, omega) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kappa, d kappa / ds, d^2 kappa / ds^2) of the effective ellipse (semi-axes `R`,
    `beta R`, turned by `omega`) at its lowest point, from (E1): `kappa = 1 / rho`,
    `kappa_s = -rho' / rho^3`, `kappa_ss = (3 rho'^2 - rho rho'') / rho^5` (`'` = d/dt, `ds =
    rho dt`), at `t = -pi/2 - omega`. 1/mm, 1/mm^2, 1/mm^3."""
    A2 = R * R
    B2 = (np.asarray(beta, float) * R) ** 2
    t = -0.5 * math.pi - np.asarray(omega, float)
    D = A2 * np.cos(t) ** 2 + B2 * np.sin(t) ** 2
    D1 = (B2 - A2) * np.sin(2.0 * t)
    D2 = 2.0 * (B2 - A2) * np.cos(2.0 * t)
    rho = A2 * B2 * D ** -1.5
    rho1 = -1.5 * A2 * B2 * D ** -2.5 * D1
    rho2 = A2 * B2 * (3.75 * D ** -3.5 * D1 * D1 - 1.5 * D ** -2.5 * D2)
    return 1.0 / rho, -rho1 / rho ** 3, (3.0 * rho1 * rho1 - rho * rho2) / rho ** 5


def axis_of(frames, beta: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """(N, 3) unit tool axes (part frame) of (`beta`, `omega`) in the CC frames (f, s, n)."""
    c = np.sqrt(np.maximum(1.0 - beta * beta, 0.0))
    return (beta[:, None] * frames.f - (c * np.sin(omega))[:, None] * frames.s
            + (c * np.cos(omega))[:, None] * frames.n)


def flat_width(R: float, beta, omega, order, kappa, kappa_s, scallop: float,
               kappa_ss=0.0) -> np.ndarray:
    """(N,) effective cutting width (mm) of the effective ellipse (semi-axes `R`, `beta R`,
    turned by `omega`) at the scallop height `scallop` (mm) (§11.3): the strip between the
    points on either side of the contact where the ellipse stands `scallop` above the section
    `Z(x) = kappa x^2/2 + kappa_s x^3/6 + (kappa_ss + 3 kappa^3) x^4/24` (its Taylor expansion
    to fourth order; `kappa_ss` the section's d^2 kappa / ds^2, 0 for a circle), found by
    bisection along the ellipse from its lowest point up to a quarter turn (at most the
    diameter). Its leading term for matched curvature and `kappa_s` is the quartic closed
    form `w = 2 (24 h / (kappa_ss(ellipse) - kappa_ss))^(1/4)` (`ellipse_curvature`). Order
    < 2: nan (no matched strip)."""
    beta, omega = np.broadcast_arrays(np.asarray(beta, float), np.asarray(omega, float))
    B = beta * R
    k, ks, kss = (np.asarray(x, float) for x in (kappa, kappa_s, kappa_ss))
    phi = np.arctan2(B * np.cos(omega), R * np.sin(omega))
    t0 = phi + math.pi  # the lowest point of Y(t) = R cos t sin w + B sin t cos w
    c, s = np.cos(omega), np.sin(omega)

    def xy(t):
        return R * np.cos(t) * c - B * np.sin(t) * s, R * np.cos(t) * s + B * np.sin(t) * c

    x0, y0 = xy(t0)
    right = np.sign(-R * np.sin(t0) * c - B * np.cos(t0) * s)  # the turn that moves to +x
    ends = []
    for side in (1.0, -1.0):
        lo, hi = np.zeros(beta.shape), np.full(beta.shape, 0.5 * math.pi)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            x, y = xy(t0 + side * right * mid)
            x = x - x0
            z = k * x ** 2 / 2 + ks * x ** 3 / 6 + (kss + 3 * k ** 3) * x ** 4 / 24
            below = (y - y0) - z <= scallop
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        ends.append(xy(t0 + side * right * lo)[0] - x0)
    return np.where(np.asarray(order) >= 2, ends[0] - ends[1], np.nan)


def ball_width(r: float, kappa, scallop: float) -> np.ndarray:
    """(N,) effective width (mm) of a ball of radius `r` at the scallop height `scallop` on a
    section of curvature `kappa` (1/mm, towards the tool): the gap `(1/r - kappa) x^2 / 2`,
    `w = 2 sqrt(2 scallop / (1/r - kappa))` (`2 sqrt(2 r h)` on a plane), at most `2 r`."""
    gap = np.maximum(1.0 / r - np.asarray(kappa, float), 1e-300)
    return np.minimum(2.0 * np.sqrt(2.0 * scallop / gap), 2.0 * r)


class ContactPlan(NamedTuple):
    """Per CC point (N,): unit `axes (N, 3)` (part frame; nan where none is feasible), `lead`,
    `tilt` (rad, docs/MATH.md §10.1), `order` of contact of the derived pose (`Contact`),
    `raised` (rad) the lead added to make the pose gouge-free, `found` whether the judge
    accepts the pose, `width` (mm) the flat-end strip's effective width at the derived (unraised)
    pose and `ball` that of a
    ball end mill of the same diameter, both at the scallop height."""

    axes: np.ndarray
    lead: np.ndarray
    tilt: np.ndarray
    order: np.ndarray
    raised: np.ndarray
    found: np.ndarray
    width: np.ndarray
    ball: np.ndarray


def contact_order_axes(part, cutter, cc: np.ndarray, normals: np.ndarray, feeds: np.ndarray,
                       cc_surface: np.ndarray, cc_uv: np.ndarray, *, judge=None,
                       scallop: float = 0.01, min_lead: float = math.radians(1.0),
                       max_lead: float = math.radians(60.0),
                       lead_step: float = math.radians(0.5)) -> ContactPlan:
    """Tool axes for flat-end (or bull-nose) finishing by the contact order of Liu et al. (n.d.) at
    CC points `cc (N, 3)` with unit normals `normals (N, 3)` (out of the material) and feed
    directions `feeds (N, 3)`, on surfaces `cc_surface (N,)` of `part` at parameters `cc_uv (N, 2)`:
    the pose of highest-order contact (`contact`) of the bottom circle (bull-nose: the corner
    centres' circle against the parallel surface), across the feed. `judge` (`poses.PoseJudge`, the
    real tool with holder on the part's triangles; None: no check) then checks every pose; a
    rejected pose has its lead raised by `lead_step` (rad) at a time, tilt kept, until the judge
    accepts it or `max_lead`: a larger lead curves the effective ellipse more (`sin(lead) / R` at
    tilt 0) and lifts the heel, so it clears a concave section and the part behind the tool.
    `scallop` (mm) sets the widths reported."""
    if cutter.ball_family or not cutter.flat_bottomed:
        raise ValueError("contact-order positioning needs a flat-end or bull-nose cutter")
    cc = np.asarray(cc, dtype=float).reshape(-1, 3)
    fr = local_frames(normals, feeds)
    uv = np.asarray(cc_uv, dtype=float).reshape(-1, 2)
    ls = local_surface(part, cc_surface, uv[:, 0], uv[:, 1])
    kappa, kappa_s = section_across(ls.offset(float(cutter.r)), fr.s)
    R = float(cutter.R)
    got = contact(kappa, kappa_s, R, min_lead=min_lead, max_lead=max_lead)
    lead, tilt = angles_from_axes(fr, axis_of(fr, got.beta, got.omega))
    raised = np.zeros(len(cc))
    found = np.ones(len(cc), bool)
    if judge is not None:
        found = judge(cc, fr.n, axes_from_angles(fr, lead, tilt))
        todo = np.flatnonzero(~found)
        while todo.size:
            raised[todo] += lead_step
            up = lead[todo] + raised[todo]
            todo = todo[up <= max_lead + 1e-12]
            if todo.size == 0:
                break
            ok = judge(cc[todo], fr.n[todo],
                       axes_from_angles(fr, lead[todo] + raised[todo], tilt[todo], todo))
            found[todo[ok]] = True
            todo = todo[~ok]
        raised[~found] = np.nan
    lead = lead + np.nan_to_num(raised)
    axes = axes_from_angles(fr, lead, tilt)
    axes[~found] = np.nan
    width = flat_width(R, got.beta, got.omega, got.order, kappa, kappa_s, scallop)
    ball = ball_width(0.5 * float(cutter.d), -ls.normal_curvature(fr.s), scallop)
    return ContactPlan(axes, lead, tilt, got.order, raised, found, width, ball)


def section_across(ls: LocalSurface, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(kappa, kappa_s) of the normal section along unit tangents `s (N, 3)` (across the feed):
    curvature bending towards the tool (1/mm) and its derivative along `s` (1/mm^2)."""
    return -ls.normal_curvature(s), ls.section_cubic(s)
