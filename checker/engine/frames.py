"""Tool frames: the rotation that takes a tool axis to +z, and grouping of rows by axis."""

from __future__ import annotations

import numpy as np


def tool_rotation(axis: np.ndarray) -> np.ndarray:
    """(3, 3) rotation Q with Q @ axis = +z for one unit tool axis (part frame); the identity
    for +z. Points go to the tool frame as `p @ Q.T` (mm, origin unchanged)."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    z = np.array([0.0, 0.0, 1.0])
    c = float(a @ z)
    if c > 1.0 - 1e-15:
        return np.eye(3)
    if c < -1.0 + 1e-15:
        return np.diag([1.0, -1.0, -1.0])
    k = np.cross(a, z)
    s = np.linalg.norm(k)
    k /= s
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def group_axes(axes: np.ndarray, decimals: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Distinct unit axes (G, 3) and, per row, the index of its group (N,)."""
    unit = axes / np.linalg.norm(axes, axis=1)[:, None]
    keys, inverse = np.unique(np.round(unit, decimals), axis=0, return_inverse=True)
    return keys / np.linalg.norm(keys, axis=1)[:, None], inverse.ravel()
