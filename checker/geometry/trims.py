"""Trimming regions in a surface's (u, v) domain: closed polyline loops and a fast vectorised
point-in-region test (numba crossing count, edges bucketed by v)."""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True)
def _crossings(u, v, x0, y0, x1, y1, vmin, dv, nb_, bstart, bedges, out):
    """out[i] = number of loop edges crossed by the ray from (u[i], v[i]) towards +u."""
    for i in range(u.shape[0]):
        b = int((v[i] - vmin) / dv)
        cnt = 0
        if 0 <= b < nb_:
            for t in range(bstart[b], bstart[b + 1]):
                e = bedges[t]
                ya, yb = y0[e], y1[e]
                if (ya > v[i]) != (yb > v[i]):
                    xc = x0[e] + (v[i] - ya) * (x1[e] - x0[e]) / (yb - ya)
                    if xc > u[i]:
                        cnt += 1
        out[i] = cnt


class LoopSet:
    """Closed polylines (each (K, 2) in (u, v)) with an even-odd inside test."""

    def __init__(self, loops: list[np.ndarray]) -> None:
        self.loops = [np.asarray(lp, dtype=np.float64).reshape(-1, 2) for lp in loops]
        segs = [
            np.stack([lp, np.roll(lp, -1, axis=0)], axis=1) for lp in self.loops if len(lp) >= 3
        ]
        seg = np.concatenate(segs) if segs else np.zeros((0, 2, 2))
        seg = seg[seg[:, 0, 1] != seg[:, 1, 1]]  # horizontal edges never cross a +u ray
        self._x0, self._y0 = seg[:, 0, 0].copy(), seg[:, 0, 1].copy()
        self._x1, self._y1 = seg[:, 1, 0].copy(), seg[:, 1, 1].copy()
        n = len(seg)
        self._nb = max(1, min(4096, n // 2))
        lo = np.minimum(self._y0, self._y1)
        hi = np.maximum(self._y0, self._y1)
        self._vmin = float(lo.min()) if n else 0.0
        span = (float(hi.max()) - self._vmin) if n else 1.0
        self._dv = span / self._nb if span > 0 else 1.0
        b0 = np.clip(((lo - self._vmin) / self._dv).astype(np.int64), 0, self._nb - 1)
        b1 = np.clip(((hi - self._vmin) / self._dv).astype(np.int64), 0, self._nb - 1)
        counts = b1 - b0 + 1
        edge_of = np.repeat(np.arange(n), counts)
        offs = np.arange(edge_of.size) - np.repeat(np.cumsum(counts) - counts, counts)
        bucket = b0[edge_of] + offs
        order = np.argsort(bucket, kind="stable")
        self._bedges = edge_of[order].astype(np.int64)
        self._bstart = np.searchsorted(bucket[order], np.arange(self._nb + 1)).astype(np.int64)

    def inside(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Bool (N,): odd number of crossings (inside an odd number of loops)."""
        u = np.ascontiguousarray(u, dtype=np.float64).ravel()
        v = np.ascontiguousarray(v, dtype=np.float64).ravel()
        out = np.zeros(u.size, dtype=np.int64)
        if self._x0.size:
            _crossings(
                u,
                v,
                self._x0,
                self._y0,
                self._x1,
                self._y1,
                self._vmin,
                self._dv,
                self._nb,
                self._bstart,
                self._bedges,
                out,
            )
        return (out & 1).astype(bool)


class UVTrim:
    """The kept region of a surface: inside the `outer` loops (even-odd; the whole domain when
    there are none) and outside every `holes` loop. STEP/IGES face wires go to `outer` (holes
    nested in the outer wire cancel by even-odd); geomdl trims with `reversed = 1` keep their
    inside (`outer`), with `reversed = 0` cut it away (`holes`)."""

    def __init__(self, outer: list[np.ndarray], holes: list[np.ndarray] | None = None) -> None:
        self._outer = LoopSet(outer)
        self._holes = LoopSet(holes or [])
        self.loops = self._outer.loops + self._holes.loops

    def contains(self, u, v) -> np.ndarray:
        """Bool mask (N,): True where (u, v) is kept."""
        u = np.asarray(u, dtype=np.float64).ravel()
        v = np.asarray(v, dtype=np.float64).ravel()
        keep = self._outer.inside(u, v) if self._outer.loops else np.ones(u.size, dtype=bool)
        if self._holes.loops:
            keep &= ~self._holes.inside(u, v)
        return keep
