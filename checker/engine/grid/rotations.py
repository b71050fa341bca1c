"""Tool frames: the rotation that takes a tool axis to +z (one or one per row), grouping of rows
by axis, and the rotation of grid points into a row's own frame inside the kernels."""

from __future__ import annotations

import numba as nb
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


def tool_rotations(axes: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations Q_i with Q_i @ axes[i] = +z for unit tool axes (N, 3) (part frame),
    the rows of `tool_rotation` computed at once."""
    a = np.asarray(axes, dtype=np.float64)
    a = a / np.linalg.norm(a, axis=1)[:, None]
    c = a[:, 2]
    k = np.zeros_like(a)
    k[:, 0], k[:, 1] = a[:, 1], -a[:, 0]
    s = np.linalg.norm(k, axis=1)
    k /= np.where(s > 0.0, s, 1.0)[:, None]
    K = np.zeros((len(a), 3, 3))
    K[:, 0, 2], K[:, 1, 2], K[:, 2, 0], K[:, 2, 1] = k[:, 1], -k[:, 0], -k[:, 1], k[:, 0]
    Q = np.eye(3) + s[:, None, None] * K + (1.0 - c)[:, None, None] * (K @ K)
    Q[c > 1.0 - 1e-15] = np.eye(3)
    Q[c < -1.0 + 1e-15] = np.diag([1.0, -1.0, -1.0])
    return Q


def rotate_rows(Q: np.ndarray, p: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
    """Points p (K, 3) through rotations Q (N, 3, 3): `Q[rows[k]] @ p[k]` (rows (K,), default
    Q has a rotation per point), without gathering Q per point."""
    if rows is None:
        return np.einsum("kij,kj->ki", Q, p)
    out = np.empty((len(rows), 3))
    _rotate_indexed(np.ascontiguousarray(Q), np.ascontiguousarray(rows, dtype=np.int64),
                    np.ascontiguousarray(p, dtype=np.float64), out, 0)
    return out


def heights(Q: np.ndarray, p: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Tool-frame heights (K,) of points p (K, 3): `(Q[rows[k]] @ p[k])[2]`."""
    out = np.empty((len(rows), 1))
    _rotate_indexed(np.ascontiguousarray(Q), np.ascontiguousarray(rows, dtype=np.int64),
                    np.ascontiguousarray(p, dtype=np.float64), out, 2)
    return out[:, 0]


@nb.njit(cache=True)
def _rotate_indexed(Q, rows, p, out, first):
    """out[k, c - first] = (Q[rows[k]] @ p[k])[c] for the components c >= first."""
    for k in range(rows.shape[0]):
        r = rows[k]
        for c in range(first, 3):
            out[k, c - first] = Q[r, c, 0] * p[k, 0] + Q[r, c, 1] * p[k, 1] + Q[r, c, 2] * p[k, 2]


def identity_rows(n: int) -> np.ndarray:
    """(n, 3, 3) identity rotations (rows that share the grid's frame)."""
    return np.broadcast_to(np.eye(3), (n, 3, 3)).copy()


@nb.njit(cache=True, forceinline=True)
def is_identity(rot, i):
    """Whether row i's rotation `rot[i]` is exactly the identity."""
    for a in range(3):
        for b in range(3):
            if rot[i, a, b] != (1.0 if a == b else 0.0):
                return False
    return True


@nb.njit(cache=True, forceinline=True)
def rotated(rot, i, xyz, p):
    """Point `xyz[p]` (grid frame) in the frame of row i: rot[i] @ xyz[p] as (x, y, z)."""
    x, y, z = xyz[p, 0], xyz[p, 1], xyz[p, 2]
    return (rot[i, 0, 0] * x + rot[i, 0, 1] * y + rot[i, 0, 2] * z,
            rot[i, 1, 0] * x + rot[i, 1, 1] * y + rot[i, 1, 2] * z,
            rot[i, 2, 0] * x + rot[i, 2, 1] * y + rot[i, 2, 2] * z)


@nb.njit(cache=True, forceinline=True)
def in_row_frame(same, rot, i, xyz, p):
    """`rotated(rot, i, xyz, p)`, or `xyz[p]` itself where `same` (`is_identity(rot, i)`: the
    row's frame is the grid's, so nothing is multiplied per point)."""
    if same:
        return xyz[p, 0], xyz[p, 1], xyz[p, 2]
    return rotated(rot, i, xyz, p)


@nb.njit(cache=True, forceinline=True)
def row_height(rot, i, xyz, p):
    """The height (z) of point `xyz[p]` (grid frame) in the frame of row i: `rotated(...)[2]`."""
    return rot[i, 2, 0] * xyz[p, 0] + rot[i, 2, 1] * xyz[p, 1] + rot[i, 2, 2] * xyz[p, 2]
