"""The exact imaginary size of surface points (surface id, u, v) for given CC rows, trims honoured:
what the refinement, the walk along the contour and the PSO baseline evaluate.

Flat-bottomed cutters (R family, psi = 0) cut nothing below their bottom plane, so the size
jumps to inf there and the minimum often lies on the contour line of the part at that height.
Points below it are moved onto the contour (Newton steps on the height in (u, v)), which turns
that jump into a smooth boundary the local steps can follow."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.engine.grid.frames import heights, rotate_rows
from checker.engine.sizes import RowFrame, pair_sizes, size_args
from checker.geometry.evaluate import SurfaceEval, evaluate_mixed
from checker.geometry.newton_uv import newton_steps
from checker.geometry.trims import pack_trims
from checker.part import Part

FLOOR_STEPS = 3  # Newton steps that bring a point below the bottom plane onto it
_CONTOUR_STEPS = 8  # the same, for points predicted along the contour (contour_walk.py)
_ABOVE = 1e-9  # mm above the bottom plane: on it the kernels already count a point as uncut
_ON_PLANE = 1e-11  # mm: a point moved onto the plane from either side is on it within this


class SurfaceSizes(NamedTuple):
    """Sizes at K surface points: `size (K,)` mm (inf outside the trim), `point (K, 3)` part
    frame, `uv (K, 2)` (moved onto the bottom plane where that applies) and the surfaces'
    evaluation `ev` there."""

    size: np.ndarray
    point: np.ndarray
    uv: np.ndarray
    ev: SurfaceEval


class Objective:
    """Imaginary size of surface points for the rows of `frame` (module docstring). `Q (N, 3,
    3)`: the rotation part frame -> tool frame of every row of `frame`."""

    def __init__(self, part: Part, cutter, frame: RowFrame, Q: np.ndarray) -> None:
        self.part, self.cutter, self.frame, self.Q = part, cutter, frame, Q
        self.trimmed = [s.id for s in part.surfaces if s.trim is not None]
        self.dom = part.domains
        flat = cutter.flat_bottomed
        self.floor = frame.fam.z0 + _ABOVE if flat else None
        self.sz = size_args(cutter, frame, np.arange(len(frame.cc)))
        self.trims = pack_trims([s.trim for s in part.surfaces])

    def exact(self, rows, sid, u, v, order: int = 2) -> SurfaceSizes:
        """The sizes on the surfaces, with their evaluation of that order."""
        u, v = u.copy(), v.copy()
        ev = evaluate_mixed(self.part, sid, u, v, order=order)
        if self.floor is not None:
            self._onto_floor(rows, sid, u, v, ev, order)
        return self._sizes(rows, sid, u, v, ev)

    def on_contour(self, rows, sid, u, v) -> SurfaceSizes:
        """The sizes of the points moved onto their row's bottom plane from either side (its
        contour), with their order-1 evaluation."""
        u, v = u.copy(), v.copy()
        ev = evaluate_mixed(self.part, sid, u, v)
        self._onto_floor(rows, sid, u, v, ev, 1, both_sides=True, steps=_CONTOUR_STEPS)
        return self._sizes(rows, sid, u, v, ev)

    def _sizes(self, rows, sid, u, v, ev: SurfaceEval) -> SurfaceSizes:
        """Sizes of the evaluated points, inf outside their surface's trim."""
        pts = ev.points
        f = pair_sizes(self.cutter, self.frame, rows, rotate_rows(self.Q, pts, rows))
        for s in self.trimmed:
            sel = np.flatnonzero(sid == s)
            if sel.size:
                out = ~np.asarray(self.part.surfaces[s].trim.contains(u[sel], v[sel]), dtype=bool)
                f[sel[out]] = np.inf
        return SurfaceSizes(f, pts, np.column_stack([u, v]), ev)

    def _onto_floor(self, rows, sid, u, v, ev, order: int, both_sides: bool = False,
                    steps: int = FLOOR_STEPS) -> None:
        """Move points below their row's bottom plane (with `both_sides`, also those above it)
        onto it in up to `steps` Newton steps (in place: u, v, ev)."""
        for _ in range(steps):
            z = heights(self.Q, ev.points, rows)
            off = np.flatnonzero(np.abs(z - self.floor[rows]) > _ON_PLANE if both_sides
                                 else z < self.floor[rows])
            if off.size == 0:
                return
            d = self.dom[sid[off]]
            a = np.column_stack([heights(self.Q, ev.du[off], rows[off]),
                                 heights(self.Q, ev.dv[off], rows[off])])  # height gradient
            excess = z[off] - self.floor[rows[off]]
            step = newton_steps(excess[:, None] * a, a[:, :, None] * a[:, None, :],
                                np.column_stack([u[off], v[off]]), d[:, :, 0], d[:, :, 1])
            ok = (step != 0.0).any(axis=1)
            off, step, d = off[ok], step[ok], d[ok]
            u[off] = np.clip(u[off] + step[:, 0], d[:, 0, 0], d[:, 0, 1])
            v[off] = np.clip(v[off] + step[:, 1], d[:, 1, 0], d[:, 1, 1])
            sub = evaluate_mixed(self.part, sid[off], u[off], v[off], order=order)
            for name in ("points", "du", "dv", "duu", "duv", "dvv")[:3 * order]:
                getattr(ev, name)[off] = getattr(sub, name)
