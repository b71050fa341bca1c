"""The exact imaginary size of surface points (surface id, u, v) for given CC rows, trims honoured:
what the refinement, the walk along the contour and the PSO baseline evaluate.

Flat-bottomed cutters (R family, psi = 0) cut nothing below their bottom plane, so the size
jumps to inf there and the minimum often lies on the contour line of the part at that height.
Points below it are moved onto the contour (Newton steps on the height in (u, v), `onto_floor`),
which turns that jump into a smooth boundary the local steps can follow. The compiled pieces
(`onto_floor`, `surface_size`) serve the compiled refinement and contour walk point by point;
`Objective.exact` runs them over a batch."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from checker.engine.grid.rotations import rotated, row_height
from checker.engine.sizes import RowFrame, point_size, size_args
from checker.geometry.evaluate import EvalScratch, eval_range, eval_scratch, packed_part
from checker.geometry.newton_uv import newton_step
from checker.geometry.trims import kept, packed_trims
from checker.part import Part

FLOOR_STEPS = 3  # Newton steps that bring a point below the bottom plane onto it
CONTOUR_STEPS = 8  # the same, for points moved onto the contour from either side
_ABOVE = 1e-9  # mm above the bottom plane: on it the kernels already count a point as uncut
_ON_PLANE = 1e-11  # mm: a point moved onto the plane from either side is on it within this
_POINT, _DU, _DV = range(3)  # rows of an evaluation: the point, S_u, S_v


class SurfaceSizes(NamedTuple):
    """Sizes at K surface points: `size (K,)` mm (inf outside the trim), `point (K, 3)` part
    frame and `uv (K, 2)` (moved onto the bottom plane where that applies)."""

    size: np.ndarray
    point: np.ndarray
    uv: np.ndarray


class PointBatch(NamedTuple):
    """Work arrays of a compiled caller for up to K surface points at a time: surfaces `sid`,
    parameters `u`, `v` (K,), their evaluation `ev` (K, slots, 3) (the point, S_u, S_v (, S_uu,
    S_uv, S_vv)), `normals` (K, 3), sizes `size` (K,), the NURBS evaluator's scratch `sc`."""

    sid: np.ndarray
    u: np.ndarray
    v: np.ndarray
    ev: np.ndarray
    normals: np.ndarray
    size: np.ndarray
    sc: EvalScratch


@nb.njit(cache=True, forceinline=True)
def point_batch(k, slots) -> PointBatch:
    """A fresh `PointBatch` for up to k points, evaluations of `slots` rows (3: order 1,
    6: order 2)."""
    return PointBatch(np.empty(k, dtype=np.int64), np.empty(k), np.empty(k),
                      np.empty((k, slots, 3)), np.empty((k, 3)), np.empty(k), eval_scratch())


@nb.njit(cache=True, _nrt=False, forceinline=True)
def onto_floor(G, Q, dom, r, level, sid, u, v, ev, normals, sc, j, order, both_sides, steps):
    """Point j (surface sid[j] at (u[j], v[j]), its evaluation of `order` in ev[j]; packed
    surfaces G) moved onto row r's bottom plane at tool-frame height `level` mm: where it lies
    below (`both_sides`: off it by more than _ON_PLANE), up to `steps` projected Newton steps
    on the height (`newton_uv.newton_step` on excess^2 / 2), clipped to the domain; u, v, ev
    updated in place."""
    lo_u, hi_u, lo_v, hi_v = dom[sid[j], 0, 0], dom[sid[j], 0, 1], dom[sid[j], 1, 0], \
        dom[sid[j], 1, 1]
    for _ in range(steps):
        z = row_height(Q, r, ev[j], _POINT)
        if not (abs(z - level) > _ON_PLANE if both_sides else z < level):
            return
        excess = z - level
        hu, hv = row_height(Q, r, ev[j], _DU), row_height(Q, r, ev[j], _DV)
        du, dv = newton_step(excess * hu, excess * hv, hu * hu, hu * hv, hv * hv, u[j], v[j],
                             lo_u, hi_u, lo_v, hi_v, False, False)
        if du == 0.0 and dv == 0.0:
            return
        u[j] = min(max(u[j] + du, lo_u), hi_u)
        v[j] = min(max(v[j] + dv, lo_v), hi_v)
        eval_range(G, sid, u, v, order, ev, normals, j, j + 1, sc)


@nb.njit(cache=True, _nrt=False, forceinline=True)
def surface_size(Q, sz, T, r, sd, u, v, ev, j):
    """The size (mm) for row r of the evaluated point ev[j] (part frame) at (u, v) on surface
    sd: `sizes.point_size` in the row's tool frame (Q), inf outside the trim (packed trims T)."""
    if not kept(T, sd, u, v):
        return np.inf
    x, y, z = rotated(Q, r, ev[j], _POINT)
    return point_size(sz, r, x, y, z)


@nb.njit(cache=True, _nrt=False, forceinline=True)
def exact_size(G, Q, floor, dom, sz, T, r, sid, u, v, ev, normals, sc, j, order):
    """The size (mm) for row r of the evaluated point j (`onto_floor`'s arguments): moved onto
    the bottom plane first where it lies below it (a flat-bottomed cutter: `floor` not empty),
    then `surface_size`."""
    if floor.shape[0]:
        onto_floor(G, Q, dom, r, floor[r], sid, u, v, ev, normals, sc, j, order, False,
                   FLOOR_STEPS)
    return surface_size(Q, sz, T, r, sid[j], u[j], v[j], ev, j)


@nb.njit(cache=True)
def _exact(G, Q, floor, dom, sz, T, rows, sid, u, v, order, size, point):
    """`Objective.exact` over the K points (u, v updated in place)."""
    ev = np.empty((rows.shape[0], 3 if order < 2 else 6, 3))
    normals = np.empty((rows.shape[0], 3))
    sc = eval_scratch()
    eval_range(G, sid, u, v, order, ev, normals, 0, rows.shape[0], sc)
    for j in range(rows.shape[0]):
        size[j] = exact_size(G, Q, floor, dom, sz, T, rows[j], sid, u, v, ev, normals, sc, j,
                             order)
        for c in range(3):
            point[j, c] = ev[j, _POINT, c]


class Objective:
    """Imaginary size of surface points for the rows of `frame` (module docstring) as the
    kernels take it: `Q (N, 3, 3)` the rotation part frame -> tool frame of every row, `G` the
    part's packed surfaces, `dom` their domains, `floor (N,)` the rows' bottom planes
    (tool-frame height, mm; empty: not a flat-bottomed cutter), `sz` the rows' `SizeArgs`,
    `trims` the packed trims."""

    def __init__(self, part: Part, cutter, frame: RowFrame, Q: np.ndarray) -> None:
        self.Q = np.ascontiguousarray(Q)
        self.G = packed_part(part)
        self.dom = part.domains
        self.floor = frame.fam.z0 + _ABOVE if cutter.flat_bottomed else np.zeros(0)
        self.sz = size_args(cutter, frame, np.arange(len(frame.cc)))
        self.trims = packed_trims(part)

    def exact(self, rows, sid, u, v, order: int = 1) -> SurfaceSizes:
        """The sizes on the surfaces (points below the bottom plane moved onto it first)."""
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        sid = np.ascontiguousarray(sid, dtype=np.int64)
        u = np.array(u, dtype=np.float64)
        v = np.array(v, dtype=np.float64)
        size, point = np.empty(len(rows)), np.empty((len(rows), 3))
        if len(rows):
            _exact(self.G, self.Q, self.floor, self.dom, self.sz, self.trims, rows, sid, u, v,
                   order, size, point)
        return SurfaceSizes(size, point, np.column_stack([u, v]))
