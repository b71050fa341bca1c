"""Trimming regions in a surface's (u, v) domain: closed polyline loops and a fast vectorised
point-in-region test (numba crossing count, edges bucketed by v)."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np


@nb.njit(cache=True, forceinline=True)
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


_BUCKETED_PER_EDGE = 8  # bucket entries per edge at most (memory in O(edges))


class LoopSet:
    """Closed polylines (each (K, 2) in (u, v)) with an even-odd inside test; edges bucketed by
    v in at most 4096 buckets and at most 8 entries per edge."""

    def __init__(self, loops: list[np.ndarray]) -> None:
        self.loops = [np.asarray(lp, dtype=np.float64).reshape(-1, 2) for lp in loops]
        segs = [
            np.stack([lp, np.roll(lp, -1, axis=0)], axis=1) for lp in self.loops if len(lp) >= 3
        ]
        seg = np.concatenate(segs) if segs else np.zeros((0, 2, 2))
        seg = seg[seg[:, 0, 1] != seg[:, 1, 1]]  # horizontal edges never cross a +u ray
        # a loop with a non-finite point is refused by the part's range check
        # (`geometry/part_limits.py`); its edges stay out of the index meanwhile
        seg = seg[np.isfinite(seg).all(axis=(1, 2))]
        self._x0, self._y0 = seg[:, 0, 0].copy(), seg[:, 0, 1].copy()
        self._x1, self._y1 = seg[:, 1, 0].copy(), seg[:, 1, 1].copy()
        n = len(seg)
        lo = np.minimum(self._y0, self._y1)
        hi = np.maximum(self._y0, self._y1)
        self._vmin = float(lo.min()) if n else 0.0
        span = (float(hi.max()) - self._vmin) if n else 1.0
        self._nb = max(1, min(4096, n // 2))
        while True:  # fewer buckets until the bucketed edges are O(n): long edges span many
            self._dv = span / self._nb if span > 0 else 1.0
            b0 = np.clip(((lo - self._vmin) / self._dv).astype(np.int64), 0, self._nb - 1)
            b1 = np.clip(((hi - self._vmin) / self._dv).astype(np.int64), 0, self._nb - 1)
            counts = b1 - b0 + 1
            if self._nb == 1 or counts.sum() <= _BUCKETED_PER_EDGE * n:
                break
            self._nb //= 2
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

    @property
    def outer(self) -> list[np.ndarray]:
        """The loops whose inside is kept."""
        return self._outer.loops

    @property
    def holes(self) -> list[np.ndarray]:
        """The loops whose inside is cut away."""
        return self._holes.loops

    def contains(self, u, v) -> np.ndarray:
        """Bool mask (N,): True where (u, v) is kept."""
        u = np.asarray(u, dtype=np.float64).ravel()
        v = np.asarray(v, dtype=np.float64).ravel()
        keep = self._outer.inside(u, v) if self._outer.loops else np.ones(u.size, dtype=bool)
        if self._holes.loops:
            keep &= ~self._holes.inside(u, v)
        return keep


class PackedTrims(NamedTuple):
    """The trims of a list of surfaces for compiled code (`kept`), in two flat arrays so that
    compiled calls pass them cheaply. Loop set k = 2s is surface s's outer loops, 2s + 1 its
    holes. `ints[_HEAD * k:]` holds (used, first edge, edge count, first bucket start, bucket
    count, first bucketed edge) of set k; `reals[3 * k:]` its (vmin, dv); its edges are rows of
    4 (x0, y0, x1, y1) in `reals` from its first edge; bucket b's edges are the local indices
    `ints[bedge + ints[start + b]:bedge + ints[start + b + 1]]`."""

    ints: np.ndarray
    reals: np.ndarray


_HEAD = 6  # ints per loop set in the header of PackedTrims.ints


def pack_trims(trims: list) -> PackedTrims:
    """`PackedTrims` of the surfaces' trims (`UVTrim` or None, in surface order)."""
    sets = []
    for t in trims:
        sets += [t._outer, t._holes] if t is not None else [LoopSet([]), LoopSet([])]
    k = len(sets)
    head, body = np.zeros((k, _HEAD), dtype=np.int64), []
    grid = np.array([(s._vmin, s._dv) for s in sets], dtype=np.float64).reshape(k, 2)
    edges = [np.column_stack([s._x0, s._y0, s._x1, s._y1]).ravel() for s in sets]
    reals_at = 2 * k + np.cumsum([0] + [len(e) for e in edges])
    ints_at = _HEAD * k
    for j, s in enumerate(sets):
        head[j] = (bool(s.loops), reals_at[j], len(s._x0), ints_at, s._nb, ints_at + s._nb + 1)
        body += [s._bstart, s._bedges]
        ints_at += len(s._bstart) + len(s._bedges)
    ints = np.concatenate([head.ravel()] + body + [np.zeros(0, np.int64)]).astype(np.int64)
    reals = np.concatenate([grid.ravel()] + edges + [np.zeros(0)])
    return PackedTrims(ints, reals)


def packed_trims(part) -> PackedTrims:
    """`pack_trims` of the trims of `part`'s surfaces, cached on the part for as long as its
    surfaces keep the same trim objects."""
    trims = [s.trim for s in part.surfaces]
    hit = part.__dict__.get("_packed_trims")
    if hit is None or len(hit[0]) != len(trims) or any(a is not b for a, b in zip(hit[0], trims,
                                                                                   strict=True)):
        hit = (trims, pack_trims(trims))
        part.__dict__["_packed_trims"] = hit
    return hit[1]


@nb.njit(cache=True, forceinline=True)
def _odd(T, k, u, v):
    """Whether (u, v) lies inside an odd number of the loops of set k of `PackedTrims` T."""
    I, R = T
    h = _HEAD * k
    e0, nb_, start, bedge = I[h + 1], I[h + 4], I[h + 3], I[h + 5]
    b = int((v - R[2 * k]) / R[2 * k + 1])
    cnt = 0
    if I[h + 2] and 0 <= b < nb_:
        for t in range(I[start + b], I[start + b + 1]):
            e = e0 + 4 * I[bedge + t]
            ya, yb = R[e + 1], R[e + 3]
            if (ya > v) != (yb > v) and R[e] + (v - ya) * (R[e + 2] - R[e]) / (yb - ya) > u:
                cnt += 1
    return cnt % 2 == 1


@nb.njit(cache=True, forceinline=True)
def kept(T, s, u, v):
    """`UVTrim.contains` of surface s at one (u, v), from `pack_trims`."""
    I = T[0]
    if I[_HEAD * 2 * s] and not _odd(T, 2 * s, u, v):
        return False
    return not (I[_HEAD * (2 * s + 1)] and _odd(T, 2 * s + 1, u, v))
