"""Imaginary sizes of (row, point) pairs in the tool frame, through the cutter's kernels, with the
engine's rules on top (docs/MATH.md §3, §5): a point within `exclusion` mm of the CC point is the
CC point itself (not a test point), and a point above the length of the cutter that would touch
it is not cut."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np

from checker import kernels
from checker.engine.grid.family import FamilyBounds

_EPS_H = kernels.EPS_H  # |n_h| below this: the normal is along the axis


@dataclass
class RowFrame:
    """The CC rows of one tool axis, tool frame, mm: `cc`, unit `n`, unit horizontal `e` (N, 3)
    (zero where undefined: normal along the axis and no tool position, the kernels then take the
    worst case over directions); `fam` the pruning bounds."""

    cc: np.ndarray
    n: np.ndarray
    e: np.ndarray
    fam: FamilyBounds
    exclusion: float


def horizontal_e(n: np.ndarray, toward: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Unit horizontal e (N, 3) from the normals' horizontal part, else from `toward` (N, 3)
    (a horizontal direction, e.g. CC -> tool axis); and the mask of rows left undefined."""
    e = np.zeros_like(n)
    h = np.hypot(n[:, 0], n[:, 1])
    ok = h > _EPS_H
    e[ok, :2] = n[ok, :2] / h[ok, None]
    if toward is not None:
        th = np.hypot(toward[:, 0], toward[:, 1])
        use = ~ok & (th > _EPS_H)
        e[use, :2] = toward[use, :2] / th[use, None]
        ok |= use
    return e, ~ok


def pair_sizes(cutter, frame: RowFrame, rows: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Imaginary size (K,) mm for pairs (row `rows (K,)`, tool-frame point `p (K, 3)`); inf for
    points the cutter family cannot touch, 0 for points inside every cutter."""
    cc, n = frame.cc[rows], frame.n[rows]
    size = cutter.imaginary_size(p, cc, n, frame.e[rows])
    q = p - cc
    near = np.einsum("ij,ij->i", q, q) < frame.exclusion ** 2
    fam = frame.fam
    tip = fam.z0[rows] - fam.t[rows] * np.where(np.isfinite(size), size, 0.0)
    too_high = p[:, 2] - tip > fam.length
    return np.where(near | too_high, np.inf, size)


class SizeArgs(NamedTuple):
    """Rows of a `RowFrame` and the cutter's constants as the numba kernels take them (tool
    frame, mm)."""

    cc: np.ndarray  # (N, 3) CC points
    n: np.ndarray  # (N, 3) unit normals
    e: np.ndarray  # (N, 3) unit horizontal directions (zero: undefined)
    z0: np.ndarray  # (N,) height of the CC point's family reference (family.py)
    t: np.ndarray  # (N,) how the tip sinks per mm of size (family.py)
    prm: np.ndarray  # the cutter's kernel parameters (kernels.py)
    ball: bool  # ball family: the ball kernel, else the APT kernel
    length: float  # cutting length above the tip
    excl2: float  # exclusion radius squared: points this near the CC point are not tested


def size_args(cutter, frame: RowFrame, rows: np.ndarray) -> SizeArgs:
    """The rows `rows (N,)` of `frame` and the cutter's constants for `point_size`."""
    fam = frame.fam
    return SizeArgs(np.ascontiguousarray(frame.cc[rows]), np.ascontiguousarray(frame.n[rows]),
            np.ascontiguousarray(frame.e[rows]), np.ascontiguousarray(fam.z0[rows]),
            np.ascontiguousarray(fam.t[rows]), cutter.kernel_params(),
            cutter.ball_family, float(fam.length), frame.exclusion ** 2)


@nb.njit(cache=True, forceinline=True)
def point_size(sz, i, x, y, z):
    """Size (mm) of row i (of `sz`, `SizeArgs`) at the point (x, y, z) of its tool frame; the
    rules of `pair_sizes`."""
    cc, n, e, z0, t, prm = sz.cc, sz.n, sz.e, sz.z0, sz.t, sz.prm
    ball, length, excl2 = sz.ball, sz.length, sz.excl2
    qx = x - cc[i, 0]
    qy = y - cc[i, 1]
    qz = z - cc[i, 2]
    if qx * qx + qy * qy + qz * qz < excl2:
        return np.inf
    if ball:
        s = kernels.ball_size(qx, qy, qz, n[i, 0], n[i, 1], n[i, 2], prm)
    else:
        s = kernels.apt_size(qx, qy, qz, n[i, 0], n[i, 1], n[i, 2], e[i, 0], e[i, 1], True, prm)
    if s < np.inf and z - (z0[i] - t[i] * s) > length:
        return np.inf
    return s


def untouchable(cutter, n: np.ndarray) -> np.ndarray:
    """(N,) rows whose CC point no cutter of the family touches tangentially (unit tool-frame
    normals `n (N, 3)`; `Cutter.untouchable`, the kernels' contact case): every size is 0
    there."""
    return cutter.untouchable(n[:, 2])
