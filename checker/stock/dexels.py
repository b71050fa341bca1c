"""The stock as Z-dexels: a square grid of vertical rays, each holding the material along it as
sorted, disjoint intervals [lo, hi] of z (docs/MATH.md §14). Part frame, mm.

Ray (i, j) (column i along x, row j along y) stands at x = x0 + (i + 0.5) h, y = y0 + (j + 0.5) h
and stands for the h x h column around it: the model's volume is h^2 times the total length of
the intervals. A ray holds at most `capacity` intervals (slots 0 .. count - 1, ascending); a cut
that would split a ray beyond it leaves that ray's material as it was (kept, never lost) and is
counted in `overflow`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_AXES = {"x": 0, "y": 1, "z": 2}


@dataclass
class Dexels:
    """`lo, hi (ny, nx, capacity)` float32 interval ends (mm), `count (ny, nx)` uint8 intervals
    per ray, grid corner `x0, y0` and spacing `h` (mm); `overflow` rays whose cut was refused
    for want of a slot."""

    x0: float
    y0: float
    h: float
    lo: np.ndarray
    hi: np.ndarray
    count: np.ndarray
    overflow: int = 0

    @property
    def nx(self) -> int:
        return self.count.shape[1]

    @property
    def ny(self) -> int:
        return self.count.shape[0]

    @property
    def capacity(self) -> int:
        return self.lo.shape[2]

    @staticmethod
    def empty(x0: float, y0: float, nx: int, ny: int, h: float, capacity: int = 4) -> Dexels:
        """A grid of nx x ny rays with no material."""
        shape = (ny, nx, capacity)
        return Dexels(float(x0), float(y0), float(h), np.zeros(shape, np.float32),
                      np.zeros(shape, np.float32), np.zeros((ny, nx), np.uint8))

    def xs(self) -> np.ndarray:
        """(nx,) the rays' x."""
        return self.x0 + (np.arange(self.nx) + 0.5) * self.h

    def ys(self) -> np.ndarray:
        """(ny,) the rays' y."""
        return self.y0 + (np.arange(self.ny) + 0.5) * self.h

    def copy(self) -> Dexels:
        return Dexels(self.x0, self.y0, self.h, self.lo.copy(), self.hi.copy(),
                      self.count.copy(), self.overflow)

    def volume(self) -> float:
        """mm^3: h^2 times the material's length over all rays."""
        slot = np.arange(self.capacity)[None, None, :] < self.count[:, :, None]
        length = np.where(slot, self.hi.astype(np.float64) - self.lo, 0.0)
        return float(length.sum() * self.h * self.h)

    def top(self) -> np.ndarray:
        """(ny, nx) float64 z of each ray's highest material (mm), nan where the ray is empty."""
        k = np.maximum(self.count.astype(np.int64) - 1, 0)[:, :, None]
        z = np.take_along_axis(self.hi, k, axis=2)[:, :, 0].astype(np.float64)
        return np.where(self.count > 0, z, np.nan)

    def bottom(self) -> np.ndarray:
        """(ny, nx) float64 z of each ray's lowest material (mm), nan where the ray is empty."""
        return np.where(self.count > 0, self.lo[:, :, 0].astype(np.float64), np.nan)

    @staticmethod
    def box(lo, hi, h: float, capacity: int = 4) -> Dexels:
        """The box [lo, hi] (3,) mm: grid corner at its lower xy corner, nx = ceil(width / h)
        (likewise ny); every ray whose centre lies inside the box's xy holds [lo_z, hi_z]."""
        lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)
                and h > 0.0):
            raise ValueError(f"a box needs lo < hi and h > 0, found lo={lo}, hi={hi}, h={h}")
        nx = max(1, math.ceil((hi[0] - lo[0]) / h - 1e-9))
        ny = max(1, math.ceil((hi[1] - lo[1]) / h - 1e-9))
        d = Dexels.empty(lo[0], lo[1], nx, ny, h, capacity)
        inside = ((d.ys()[:, None] <= hi[1] + 1e-9 * h)
                  & (d.xs()[None, :] <= hi[0] + 1e-9 * h))
        d.lo[:, :, 0] = np.where(inside, lo[2], 0.0)
        d.hi[:, :, 0] = np.where(inside, hi[2], 0.0)
        d.count[:] = inside
        return d

    @staticmethod
    def cylinder(axis: str, centre, radius: float, start: float, end: float, h: float,
                 capacity: int = 4) -> Dexels:
        """The solid cylinder of `radius` (mm) about the line parallel to `axis` ('x', 'y' or
        'z') through `centre` (2,) (the line's other two coordinates in x, y, z order), from
        `start` to `end` along the axis. Each ray holds its exact chord: about x or y the
        interval z = c_z -+ sqrt(radius^2 - e^2) (e the ray's distance across the axis), about
        z the interval [start, end] over the disk."""
        if axis not in _AXES:
            raise ValueError(f"a cylinder's axis is 'x', 'y' or 'z', found {axis!r}")
        if not (radius > 0.0 and end > start and h > 0.0):
            raise ValueError(f"a cylinder needs radius > 0, start < end and h > 0, found "
                             f"radius={radius}, start={start}, end={end}, h={h}")
        c0, c1 = float(centre[0]), float(centre[1])
        if axis == "z":
            lo = np.array([c0 - radius, c1 - radius])
            hi = np.array([c0 + radius, c1 + radius])
        elif axis == "x":
            lo, hi = np.array([start, c0 - radius]), np.array([end, c0 + radius])
        else:
            lo, hi = np.array([c0 - radius, start]), np.array([c0 + radius, end])
        nx = max(1, math.ceil((hi[0] - lo[0]) / h - 1e-9))
        ny = max(1, math.ceil((hi[1] - lo[1]) / h - 1e-9))
        d = Dexels.empty(lo[0], lo[1], nx, ny, h, capacity)
        x, y = np.meshgrid(d.xs(), d.ys())
        if axis == "z":
            inside = (x - c0) ** 2 + (y - c1) ** 2 <= radius * radius
            zlo = np.full(x.shape, float(start))
            zhi = np.full(x.shape, float(end))
        else:
            along, across = (x, y) if axis == "x" else (y, x)
            e2 = radius * radius - (across - c0) ** 2
            inside = (e2 > 0.0) & (along >= start) & (along <= end)
            half = np.sqrt(np.maximum(e2, 0.0))
            zlo, zhi = c1 - half, c1 + half
        d.lo[:, :, 0] = np.where(inside, zlo, 0.0)
        d.hi[:, :, 0] = np.where(inside, zhi, 0.0)
        d.count[:] = inside
        return d
