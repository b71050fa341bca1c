"""The 4-axis convention (docs/MATH.md §1): a rotary table about machine +Y through
`table_center`.

Commanding B = b turns the part by b about +Y (right-hand rule): a part point p sits at machine
position Ry(b) (p - c) + c. The tool axis seen in the part frame is (-sin b, 0, cos b), so a CL
axis (i, 0, k) maps to b = atan2(-i, k). Machines that count B the other way set b_direction = -1
(handled by the post-processor: B here is always the angle of docs/MATH.md §1). Angles in
degrees at this module's boundary.
"""

from __future__ import annotations

import numpy as np

from checker.errors import PathcheckError, raise_at_first


def axis_for_b(b_deg: np.ndarray) -> np.ndarray:
    """Tool axis in the part frame at table angle B: (N,) degrees -> (N, 3) unit vectors."""
    b = np.radians(np.asarray(b_deg, dtype=float))
    return np.stack([-np.sin(b), np.zeros_like(b), np.cos(b)], axis=-1)


def b_for_axis(axes: np.ndarray) -> np.ndarray:
    """Table angle B (degrees) of part-frame tool axes (i, 0, k): (N, 3) -> (N,)."""
    axes = np.asarray(axes, dtype=float)
    return np.degrees(np.arctan2(-axes[..., 0], axes[..., 2]))


def rotate_about_y(points: np.ndarray, b_deg: np.ndarray, center: np.ndarray) -> np.ndarray:
    """Ry(b) (p - c) + c for points (N, 3) and angles (N,) or scalar, degrees: part -> machine."""
    b = np.radians(np.asarray(b_deg, dtype=float))
    c, s = np.cos(b), np.sin(b)
    d = np.asarray(points, dtype=float) - center
    x = c * d[..., 0] + s * d[..., 2]
    z = -s * d[..., 0] + c * d[..., 2]
    return np.stack([x, d[..., 1], z], axis=-1) + center


def check_four_axis(axes: np.ndarray, lines: np.ndarray | None, path: str | None,
                    tolerance: float) -> None:
    """Raise when a tool axis is not perpendicular to Y (|j| > tolerance): the path is not 4-axis
    about Y, and is never silently projected. Names the first offending line (of `lines`)."""
    axes = np.asarray(axes, dtype=float)
    bad = np.abs(axes[:, 1]) > tolerance
    raise_at_first(bad, lines, lambda k: (
        f"not a 4-axis path about Y: tool axis {np.round(axes[k], 6).tolist()} has "
        f"j = {axes[k, 1]:.6g} (expected |j| <= {tolerance:g}); {int(bad.sum())} axes like it"),
        path=path, code="not-4-axis")


def check_b_range(b_min: float, b_max: float, limit_min: float, limit_max: float) -> None:
    """A requested B range must be ordered and inside the machine's limits (degrees)."""
    if not (np.isfinite(b_min) and np.isfinite(b_max)) or b_min >= b_max:
        raise PathcheckError(
            f"B range {b_min:g}:{b_max:g}: expected LO:HI with LO < HI, degrees", code="b-range"
        )
    if b_min < limit_min - 1e-9 or b_max > limit_max + 1e-9:
        raise PathcheckError(
            f"B range {b_min:g}:{b_max:g} is outside the machine's limits "
            f"{limit_min:g}:{limit_max:g} degrees",
            code="b-range",
        )
