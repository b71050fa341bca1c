"""Shank and holder clearance at every pose.

In the tool frame (tip at the origin, axis +z) the tool above its flutes is a stack of cylinders:
the shank (radius `shank_diameter/2`) from the flute length up to the stick-out, then the holder
(radius `holder_diameter/2`) for `holder_length`. A test point of the part inside either one is a
holder hit. The minimum stick-out that clears the holder is the height of the highest test point
within the holder's radius: the holder's face must sit above it. mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange


@dataclass(frozen=True)
class HolderCheck:
    """Per pose: whether the shank or holder touches the part, the deepest intrusion (mm, radial),
    and the minimum stick-out that would clear the holder (mm; 0 when nothing is in its way)."""

    hit: np.ndarray
    intrusion: np.ndarray
    required_stickout: np.ndarray


@njit(cache=True, parallel=True)
def _holder_kernel(points, tips, axes, flute, stickout, shank_r, holder_r, holder_top):
    n = tips.shape[0]
    hit = np.zeros(n, dtype=np.bool_)
    intrusion = np.zeros(n)
    required = np.zeros(n)
    for i in prange(n):
        ax, ay, az = axes[i, 0], axes[i, 1], axes[i, 2]
        worst = 0.0
        need = 0.0
        for m in range(points.shape[0]):
            dx = points[m, 0] - tips[i, 0]
            dy = points[m, 1] - tips[i, 1]
            dz = points[m, 2] - tips[i, 2]
            z = dx * ax + dy * ay + dz * az
            if z <= 0.0 or z > holder_top:
                continue
            rx = dx - z * ax
            ry = dy - z * ay
            rz = dz - z * az
            rho = np.sqrt(rx * rx + ry * ry + rz * rz)
            if rho < holder_r and z > need:
                need = z
            if z > flute and z <= stickout and rho < shank_r:
                worst = max(worst, shank_r - rho)
            elif z > stickout and rho < holder_r:
                worst = max(worst, holder_r - rho)
        hit[i] = worst > 0.0
        intrusion[i] = worst
        required[i] = need
    return hit, intrusion, required


def check_holder(
    points: np.ndarray,
    tips: np.ndarray,
    axes: np.ndarray,
    *,
    flute_length: float,
    stickout: float,
    shank_diameter: float,
    holder_diameter: float,
    holder_length: float,
) -> HolderCheck:
    """Shank/holder hits of N poses (tips, unit axes (N, 3), part frame) against test points
    (M, 3) of the part. Lengths are measured from the tool tip along the axis, mm."""
    hit, intrusion, required = _holder_kernel(
        np.ascontiguousarray(points, dtype=float),
        np.ascontiguousarray(tips, dtype=float),
        np.ascontiguousarray(axes, dtype=float),
        float(flute_length),
        float(stickout),
        0.5 * float(shank_diameter),
        0.5 * float(holder_diameter),
        float(stickout + holder_length),
    )
    return HolderCheck(hit, intrusion, required)
