"""Nearest points in 3-D: a k-d tree over (N, 3) points, mm (pykdtree, which imports at once where
scipy.spatial adds a noticeable part of every command's start), with scipy's cKDTree conventions:
integer indices, and a missing neighbour (k > N) at index N and distance inf."""

from __future__ import annotations

import numpy as np
from pykdtree.kdtree import KDTree


class PointTree:
    """k-d tree over `data (N, 3)` (float64, C-contiguous copy kept for its lifetime)."""

    def __init__(self, points: np.ndarray) -> None:
        self.data = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        self._tree = KDTree(self.data) if len(self.data) else None

    def query(self, x: np.ndarray, k: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Distances and indices (intp) of the k nearest points to each of `x (M, 3)`: shape
        (M,) for k = 1, else (M, k), nearest first."""
        x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 3)
        n = len(self.data)
        if self._tree is None or not len(x):
            shape = (len(x),) if k == 1 else (len(x), k)
            return np.full(shape, np.inf), np.full(shape, n, dtype=np.intp)
        dist, idx = self._tree.query(x, k=k)
        idx = idx.astype(np.intp)
        missing = idx >= n
        if missing.any():
            idx[missing], dist[missing] = n, np.inf
        return dist, idx
