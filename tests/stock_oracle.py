"""An independent oracle of the stock simulation for 3-axis programs: a brute-force height field.

The stock is a box; its top surface is a height per point of a fine XY grid. Every move of the
program is sampled finely (poses at most `step` mm apart along the move) and at every pose the
exact lower profile of the cutter (flat, ball or bull-nose, written here from the APT
parameters: no code of pathcheck's) is dropped on the grid points within its radius: the height
there becomes min(height, tip z + h(d)), d the point's distance from the axis. Between two poses
`step` mm apart the true sweep lies lower by at most R - sqrt(R^2 - (step / 2)^2) for a corner
of radius R (flat end: the sharp edge, the same with R the cutter radius), which the tests add
to their bound.

Per move the oracle also says how deep it cut (the largest drop of the height at one grid
point), so air cuts (feed moves that cut nothing) can be counted independently. Part frame, mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Profile:
    """A flat, ball or bull-nose end mill: radius `R` (half the diameter) and corner radius
    `r` (0 flat, R ball), mm."""

    R: float
    r: float

    def height(self, d: np.ndarray) -> np.ndarray:
        """The lowest point of the cutter at distance `d` from its axis, above its tip (mm;
        inf beyond R)."""
        d = np.asarray(d, float)
        flat = self.R - self.r
        out = np.full(d.shape, np.inf)
        inner = d <= flat
        out[inner] = 0.0
        ring = (d > flat) & (d <= self.R)
        e = d[ring] - flat
        out[ring] = self.r - np.sqrt(np.maximum(self.r * self.r - e * e, 0.0))
        return out

    def sampling_error(self, step: float) -> float:
        """How much higher than the true sweep the sampled one can stay between poses `step`
        mm apart (mm)."""
        rad = self.r if self.r > 0.0 else self.R
        half = min(0.5 * step, rad)
        return float(rad - np.sqrt(rad * rad - half * half))


@dataclass
class HeightField:
    """Heights `z (ny, nx)` at grid points x0 + i h, y0 + j h (mm)."""

    x0: float
    y0: float
    h: float
    z: np.ndarray

    @staticmethod
    def box(lo, hi, h: float) -> HeightField:
        nx = int(np.floor((hi[0] - lo[0]) / h)) + 1
        ny = int(np.floor((hi[1] - lo[1]) / h)) + 1
        return HeightField(float(lo[0]), float(lo[1]), h, np.full((ny, nx), float(hi[2])))

    def at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Heights at points (nearest grid point; nan outside)."""
        i = np.rint((np.asarray(x) - self.x0) / self.h).astype(int)
        j = np.rint((np.asarray(y) - self.y0) / self.h).astype(int)
        ok = (i >= 0) & (j >= 0) & (i < self.z.shape[1]) & (j < self.z.shape[0])
        out = np.full(i.shape, np.nan)
        out[ok] = self.z[j[ok], i[ok]]
        return out

    def drop(self, profile: Profile, tip: np.ndarray) -> float:
        """Cut the field with the cutter at `tip (3,)`; returns the largest drop (mm)."""
        R, h = profile.R, self.h
        i0 = max(int(np.ceil((tip[0] - R - self.x0) / h)), 0)
        i1 = min(int(np.floor((tip[0] + R - self.x0) / h)), self.z.shape[1] - 1)
        j0 = max(int(np.ceil((tip[1] - R - self.y0) / h)), 0)
        j1 = min(int(np.floor((tip[1] + R - self.y0) / h)), self.z.shape[0] - 1)
        if i1 < i0 or j1 < j0:
            return 0.0
        xs = self.x0 + np.arange(i0, i1 + 1) * h
        ys = self.y0 + np.arange(j0, j1 + 1) * h
        d = np.hypot(xs[None, :] - tip[0], ys[:, None] - tip[1])
        low = tip[2] + profile.height(d)
        window = self.z[j0:j1 + 1, i0:i1 + 1]
        cut = np.maximum(window - low, 0.0)
        np.minimum(window, low, out=window)
        return float(cut.max(initial=0.0))


def simulate(field: HeightField, profile: Profile, tips: np.ndarray, start: np.ndarray,
             step: float) -> np.ndarray:
    """Cut `field` along the program whose poses are `tips (P, 3)`: pose i is reached by a move
    from pose i - 1 unless `start[i]` (then the tool is put there). Returns per pose the largest
    drop its move made (mm)."""
    cut = np.zeros(len(tips))
    for i in range(len(tips)):
        if start[i] or i == 0:
            cut[i] = field.drop(profile, tips[i])
            continue
        a, b = tips[i - 1], tips[i]
        n = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        for t in np.arange(1, n + 1) / n:
            cut[i] = max(cut[i], field.drop(profile, a + t * (b - a)))
    return cut
