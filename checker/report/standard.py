"""Standard cutters for the colour map of thesis figs 4-2 and 4-3: at each CC point the largest
standard cutter of the job's family whose size does not exceed the allowable size. The cutters
come from the tool library (`checker/resources/tools.toml`, same kind and corner radius); a
family the library lacks falls back to `report.standard_diameters` of the config."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from checker.cutter import parse_cutter
from checker.errors import PathcheckError
from checker.tool_library import ToolLibrary, largest_fitting, load_tool_library


@dataclass(frozen=True)
class StandardCutters:
    """Standard cutters of one family, ascending: names and sizes in the allowable variable
    (R for flat/bull-nose/APT, r for ball; mm)."""

    names: tuple[str, ...]
    sizes: np.ndarray

    def largest(self, allowable: np.ndarray) -> np.ndarray:
        """(N,) index into `names` of the largest standard cutter with size <= allowable (mm;
        nan = unbounded), -1 where none fits."""
        return largest_fitting(self.sizes, np.where(np.isnan(allowable), np.inf, allowable))

    def name_of(self, index: int) -> str:
        return "none" if index < 0 else self.names[index]


@lru_cache(maxsize=1)
def _library() -> ToolLibrary:
    return load_tool_library()


def _parsed_cutter(cutter: str | None):
    """The real cutter of a stored `CUTTER/...` statement, None when there is none or it does
    not parse (a store written by another version)."""
    if not cutter:
        return None
    try:
        return parse_cutter(cutter)
    except PathcheckError:
        return None


def standard_cutters(
    kind: str | None, cutter: str | None, cutter_size: float | None,
    diameters: tuple[float, ...],
) -> StandardCutters:
    """The standard cutters of the family of the real cutter (`kind`, its APT CUTTER/d,r,e,f,a,b
    statement and its size, mm). Library family: same kind (and corner radius r for the R
    families, taper angle b for tapered balls); otherwise the config diameters D with size
    D/2 - (d/2 - size of the real cutter) > 0, i.e. the real cutter's corner kept."""
    real = _parsed_cutter(cutter)
    if kind and real is not None:
        theta = real.theta if real.ball_family and real.theta > 0.0 else None
        family = _library().family(kind, real.family_corner, theta=theta)
        if family:
            return StandardCutters(
                tuple(t.name or f"D{t.d:g}" for t in family),
                np.array([t.size for t in family], dtype=float),
            )
    offset = max(real.d / 2.0 - cutter_size, 0.0) if real is not None and cutter_size else 0.0
    d = np.sort(np.asarray(diameters, dtype=float))
    d = d[d / 2.0 - offset > 0.0]  # a smaller diameter has no cutter with this corner
    return StandardCutters(tuple(f"D{x:g}" for x in d), d / 2.0 - offset)


def per_region(
    standard: StandardCutters, allowable: np.ndarray, surface: np.ndarray
) -> list[tuple[int, str]]:
    """(surface id, name of the largest standard cutter safe on all the given CC points of it)
    per region; surface -1 (unknown) is reported as region -1."""
    ids, inverse = np.unique(surface, return_inverse=True)
    a = np.where(np.isnan(allowable), np.inf, allowable)
    least = np.full(len(ids), np.inf)
    np.minimum.at(least, inverse, a)
    best = standard.largest(least)
    return [(int(i), standard.name_of(int(b))) for i, b in zip(ids, best, strict=True)]
