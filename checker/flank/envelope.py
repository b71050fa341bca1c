"""The grazing (characteristic) curves of a cutter of revolution along a `ToolMotion` (Gong and
Wang 2009 §2; docs/MATH.md §12.2): per height z above the tip the angle(s) phi where the surface
velocity is tangent, n . v = 0, which is `A cos(phi) + B sin(phi) = C` in closed form. The
envelope surface is the union of the grazing curves over t. Part frame, mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.cutter import Cutter
from checker.flank.spline_motion import MotionState


def profile(cutter: Cutter, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rho, slope) (Z,): the radius of the cutter's surface of revolution at height z (mm
    above the tip) and d rho / dz, as the cutter answers them (`Cutter.profile_radius`,
    `Cutter.profile_slope`; docs/MATH.md §2)."""
    return cutter.profile_radius(z), cutter.profile_slope(z)


@dataclass(frozen=True)
class Grazing:
    """Grazing points at (T, Z) = (parameters, heights): `points` and unit `normals` (the
    cutter's outward normal, which is the envelope's), `phi` the angle about the axis from the
    frame's e1 (rad), `valid` False where no grazing point exists at that height (the motion is
    along the axis there, or the tool does not move)."""

    points: np.ndarray
    normals: np.ndarray
    phi: np.ndarray
    valid: np.ndarray


def axis_frame(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2) (T, 3): unit vectors with (e1, e2, a) right-handed and orthonormal."""
    ref = np.zeros_like(a)
    ref[np.arange(len(a)), np.argmin(np.abs(a), axis=1)] = 1.0
    e1 = np.cross(ref, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(a, e1)


def grazing(cutter: Cutter, state: MotionState, z: np.ndarray, side: np.ndarray) -> Grazing:
    """The grazing curve of each state (T poses) at heights z (Z,) mm above the tip. Of the two
    roots phi = atan2(B, A) +- acos(C / hypot(A, B)) the one whose radial direction is nearer
    `side` (T, 3) is kept (the side of the design surface).

    With P = tip + z a + rho u, u = cos(phi) e1 + sin(phi) e2, the velocity of the rigid motion
    is v = tip' + (a x a') x (P - tip) and n ~ u - rho' a, so n . v = 0 reads
    u . (tip' + (z + rho rho') a') = rho' a . tip'."""
    z = np.asarray(z, dtype=float)
    rho, slope = profile(cutter, z)
    a, da, dtip = state.axis, state.axis_dt, state.tip_dt
    e1, e2 = axis_frame(a)
    w = dtip[:, None, :] + (z + rho * slope)[None, :, None] * da[:, None, :]
    A = np.einsum("tzk,tk->tz", w, e1)
    B = np.einsum("tzk,tk->tz", w, e2)
    C = slope[None, :] * np.einsum("tk,tk->t", a, dtip)[:, None]
    mag = np.hypot(A, B)
    speed = np.linalg.norm(dtip, axis=1) + np.abs(z).max(initial=1.0) * np.linalg.norm(da, axis=1)
    floor = 1e-12 * np.maximum(speed, 1e-300)[:, None]  # |(A, B)| of a tool at rest
    valid = (mag > floor) & (np.abs(C) <= mag)
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = np.arccos(np.clip(C / mag, -1.0, 1.0))
    centre = np.arctan2(B, A)
    phis = np.stack([centre + delta, centre - delta])  # (2, T, Z)
    s1, s2 = np.einsum("tk,tk->t", side, e1), np.einsum("tk,tk->t", side, e2)
    toward = np.cos(phis) * s1[None, :, None] + np.sin(phis) * s2[None, :, None]
    phi = np.where(toward[0] >= toward[1], phis[0], phis[1])
    u = np.cos(phi)[..., None] * e1[:, None, :] + np.sin(phi)[..., None] * e2[:, None, :]
    points = state.tip[:, None, :] + z[None, :, None] * a[:, None, :] + rho[None, :, None] * u
    normals = (u - slope[None, :, None] * a[:, None, :]) / np.sqrt(1.0 + slope**2)[None, :, None]
    ok = valid & np.isfinite(phi) & np.isfinite(slope)[None, :]
    return Grazing(points, normals, phi, ok)
