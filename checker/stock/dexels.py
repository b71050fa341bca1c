"""The stock as Z-dexels: a square grid of vertical rays, each holding the material along it as
sorted, disjoint intervals [lo, hi] of z (docs/MATH.md §14). Part frame, mm.

Ray (i, j) (column i along x, row j along y) stands at x = x0 + (i + 0.5) h, y = y0 + (j + 0.5) h
and stands for the h x h column around it: the model's volume is h^2 times the total length of
the intervals. A ray holds at most `capacity` intervals (slots 0 .. count - 1, ascending); a cut
that would split a ray beyond it leaves that ray's material as it was (kept, never lost) and is
counted in `overflow`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
