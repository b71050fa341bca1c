"""Standard cutters for the colour map of thesis figs 4-2 and 4-3: at each CC point the largest
standard cutter of the job's family whose size does not exceed the allowable size."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

_FIRST_NUMBER = re.compile(r"/\s*([-+0-9.eE]+)")


@dataclass(frozen=True)
class StandardCutters:
    """Standard diameters (mm, ascending) and their sizes in the allowable variable of a job's
    family (R for flat/bull-nose/APT, r for ball): size = D/2 - offset, where offset = d/2 - size
    of the real cutter (0 for flat and ball, the corner radius for a bull-nose)."""

    diameters: np.ndarray
    sizes: np.ndarray

    @property
    def names(self) -> list[str]:
        return [f"D{d:g}" for d in self.diameters]

    def largest(self, allowable: np.ndarray) -> np.ndarray:
        """(N,) index into `diameters` of the largest standard cutter with size <= allowable
        (mm; nan = unbounded), -1 where none fits."""
        a = np.where(np.isnan(allowable), np.inf, allowable)
        return np.searchsorted(self.sizes, a, side="right") - 1

    def name_of(self, index: int) -> str:
        return "none" if index < 0 else self.names[index]


def standard_cutters(
    diameters: tuple[float, ...], cutter: str | None, cutter_size: float | None
) -> StandardCutters:
    """The standard cutters of the family of `cutter` (an APT CUTTER/ statement) whose real size
    in the allowable variable is `cutter_size` (mm)."""
    d = np.sort(np.asarray(diameters, dtype=float))
    offset = 0.0
    match = _FIRST_NUMBER.search(cutter or "")
    if match and cutter_size is not None:
        try:
            offset = max(float(match.group(1)) / 2.0 - cutter_size, 0.0)
        except ValueError:
            offset = 0.0
    keep = d / 2.0 - offset > 0
    return StandardCutters(diameters=d[keep], sizes=d[keep] / 2.0 - offset)


def per_region(
    standard: StandardCutters, allowable: np.ndarray, surface: np.ndarray
) -> list[tuple[int, str]]:
    """(surface id, name of the largest standard cutter safe on all its CC points) per region;
    surface -1 (unknown) is reported as region -1."""
    ids, inverse = np.unique(surface, return_inverse=True)
    a = np.where(np.isnan(allowable), np.inf, allowable)
    least = np.full(len(ids), np.inf)
    np.minimum.at(least, inverse, a)
    best = standard.largest(least)
    return [(int(i), standard.name_of(int(b))) for i, b in zip(ids, best, strict=True)]
