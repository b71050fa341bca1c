"""Trimming regions in a surface's (u, v) domain: closed polyline loops and a fast vectorised
point-in-region test (numba crossing count, edges bucketed by v)."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np


@nb.njit(cache=True, inline="always")
def _crossing_count(u, v, x0, y0, x1, y1, vmin, dv, nb_, bstart, bedges):
    """Number of loop edges crossed by the ray from (u, v) towards +u."""
    b = int((v - vmin) / dv)
    cnt = 0
    if 0 <= b < nb_:
        for t in range(bstart[b], bstart[b + 1]):
            e = bedges[t]
            ya, yb = y0[e], y1[e]
            if (ya > v) != (yb > v):
                xc = x0[e] + (v - ya) * (x1[e] - x0[e]) / (yb - ya)
                if xc > u:
                    cnt += 1
    return cnt


@nb.njit(cache=True)
def _crossings(u, v, x0, y0, x1, y1, vmin, dv, nb_, bstart, bedges, out):
    """out[i] = number of loop edges crossed by the ray from (u[i], v[i]) towards +u."""
    for i in range(u.shape[0]):
        out[i] = _crossing_count(u[i], v[i], x0, y0, x1, y1, vmin, dv, nb_, bstart, bedges)


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


class PackedTrims(NamedTuple):
    """The trims of a list of surfaces for compiled code (`kept`): loop set 2s is surface s's
    outer loops, 2s + 1 its holes; `used[k]` whether set k has loops, its edges are
    `edges[eo[k]:eo[k + 1]]` (x0, y0, x1, y1 per row), its v buckets `bstart[bo[k]:...]` into
    `bedges[go[k]:...]` (local indices), `grid[k]` = (vmin, dv, buckets)."""

    used: np.ndarray
    edges: np.ndarray
    eo: np.ndarray
    bstart: np.ndarray
    bo: np.ndarray
    bedges: np.ndarray
    go: np.ndarray
    grid: np.ndarray


def pack_trims(trims: list) -> PackedTrims:
    """`PackedTrims` of the surfaces' trims (`UVTrim` or None, in surface order)."""
    sets = []
    for t in trims:
        sets += [t._outer, t._holes] if t is not None else [LoopSet([]), LoopSet([])]
    edges = [np.column_stack([s._x0, s._y0, s._x1, s._y1]) for s in sets]
    return PackedTrims(
        used=np.array([bool(s.loops) for s in sets], dtype=np.bool_),
        edges=np.concatenate(edges + [np.zeros((0, 4))]),
        eo=np.cumsum([0] + [len(e) for e in edges]).astype(np.int64),
        bstart=np.concatenate([s._bstart for s in sets] + [np.zeros(0, np.int64)]),
        bo=np.cumsum([0] + [len(s._bstart) for s in sets]).astype(np.int64),
        bedges=np.concatenate([s._bedges for s in sets] + [np.zeros(0, np.int64)]),
        go=np.cumsum([0] + [len(s._bedges) for s in sets]).astype(np.int64),
        grid=np.array([(s._vmin, s._dv, s._nb) for s in sets] + [(0.0, 1.0, 0)], dtype=np.float64),
    )


@nb.njit(cache=True, inline="always")
def _odd(T, k, u, v):
    """Whether (u, v) lies inside an odd number of the loops of set k of `PackedTrims` T."""
    e0, e1 = T.eo[k], T.eo[k + 1]
    if e1 == e0:
        return False
    E = T.edges[e0:e1]
    n = _crossing_count(u, v, E[:, 0], E[:, 1], E[:, 2], E[:, 3], T.grid[k, 0], T.grid[k, 1],
                        int(T.grid[k, 2]), T.bstart[T.bo[k]:T.bo[k + 1]],
                        T.bedges[T.go[k]:T.go[k + 1]])
    return n % 2 == 1


@nb.njit(cache=True, inline="always")
def kept(T, s, u, v):
    """`UVTrim.contains` of surface s at one (u, v), from `pack_trims`."""
    if T.used[2 * s] and not _odd(T, 2 * s, u, v):
        return False
    return not (T.used[2 * s + 1] and _odd(T, 2 * s + 1, u, v))
