"""The arrays the mesh kernels take, checked and made C-contiguous and writable (a read-only or
strided array would make numba compile a kernel once more for that type)."""

from __future__ import annotations

import numpy as np

from checker.mesh.core import Tools
from checker.mesh.tool import ToolPieces


def contiguous(a, dtype) -> np.ndarray:
    """`a` as a C-contiguous, writable array of `dtype` (a copy only when needed)."""
    return np.require(a, dtype=dtype, requirements=["C", "W"])


def rows_of_three(a, name: str, n: int | None = None) -> np.ndarray:
    """`a` as an (N, 3) float array, finite; a (3,) `a` is repeated when `n` rows are asked.
    ValueError naming `name` otherwise."""
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1 and a.shape == (3,) and n is not None:
        a = np.broadcast_to(a, (n, 3))
    a = contiguous(a, np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {a.shape}")
    if n is not None and len(a) != n:
        raise ValueError(f"{name} must have {n} rows, got {len(a)}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite")
    return a


def unit_rows(axes: np.ndarray) -> np.ndarray:
    """The rows of `axes (N, 3)` normalised; ValueError for a zero row."""
    n = np.linalg.norm(axes, axis=1)
    if (n <= 0.0).any():
        raise ValueError("axes must be non-zero")
    return contiguous(axes / n[:, None], np.float64)


def plain(*records: tuple) -> list[tuple]:
    """The records (NamedTuples) as plain tuples, for a kernel's arguments, which rebuilds them:
    numba types a plain tuple at once, while a NamedTuple argument's class is first matched
    against every registered abstract base class (once per class and process, slow once numba's
    parallel backend has loaded)."""
    return [tuple(r) for r in records]


def one_tool(pieces: ToolPieces) -> Tools:
    """The `core.Tools` of the one tool `pieces`."""
    return Tools(contiguous(pieces.prof, np.float64), contiguous(pieces.nprof, np.int64),
                 contiguous(pieces.rho, np.float64), contiguous(pieces.kind, np.int64),
                 np.array([0, len(pieces)], dtype=np.int64))
