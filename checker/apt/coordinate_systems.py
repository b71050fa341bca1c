"""Coordinate-system statements -> 4x4 matrices (file frame -> part frame, mm), applied in bulk."""

from __future__ import annotations

import numpy as np

from checker.errors import PathcheckError

ORTHO_TOL = 1e-3  # printed rotation matrices carry 6-7 decimals


def _check_rotation(R: np.ndarray, word: str, *, path: str, line: int) -> None:
    err = np.abs(R.T @ R - np.eye(3)).max()
    if err > ORTHO_TOL or np.linalg.det(R) <= 0:
        raise PathcheckError(
            f"{word}/: expected an orthonormal right-handed rotation, found one off by {err:.3g} "
            f"(det {np.linalg.det(R):.4g})",
            path=path,
            line=line,
            code="parse",
        )


def csys_matrix(v: tuple[float, ...], scale: float, *, path: str, line: int) -> np.ndarray:
    """``CSYS/`` with 12 values, a 3x4 matrix row by row ``[R | t]``: part = R file + t."""
    M = np.eye(4)
    M[:3, :] = np.asarray(v, dtype=float).reshape(3, 4)
    M[:3, 3] *= scale
    _check_rotation(M[:3, :3], "CSYS", path=path, line=line)
    return M


def msys_matrix(v: tuple[float, ...], scale: float, *, path: str, line: int) -> np.ndarray:
    """NX ``MSYS/ox,oy,oz, xi,xj,xk, yi,yj,yk``: the machine coordinate system's origin and X, Y
    axes in the part frame; CL points are given in it."""
    o, x, y = (np.asarray(v[k : k + 3], dtype=float) for k in (0, 3, 6))
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2] = x, y, np.cross(x, y)
    M[:3, 3] = o * scale
    _check_rotation(M[:3, :3], "MSYS", path=path, line=line)
    return M


def apply_frames(
    tip: np.ndarray, axis: np.ndarray, frame: np.ndarray, matrices: list[np.ndarray | None]
) -> None:
    """In place: rows of ``tip`` (N, 3) mm and ``axis`` (N, 3) with ``frame[n] = k`` are mapped
    by ``matrices[k]`` (None or ``frame < 0``: identity)."""
    for k in np.unique(frame):
        if k < 0 or matrices[k] is None:
            continue
        M = matrices[k]
        sel = frame == k
        tip[sel] = tip[sel] @ M[:3, :3].T + M[:3, 3]
        axis[sel] = axis[sel] @ M[:3, :3].T


def to_frame(p_part: np.ndarray, M: np.ndarray | None) -> np.ndarray:
    """Part-frame point (3,) -> the frame of ``M`` (inverse of `apply_frames`)."""
    if M is None:
        return p_part
    return M[:3, :3].T @ (p_part - M[:3, 3])


def from_frame(p: np.ndarray, M: np.ndarray | None) -> np.ndarray:
    """A point (3,) in the frame of ``M`` -> part frame."""
    if M is None:
        return p
    return M[:3, :3] @ p + M[:3, 3]
