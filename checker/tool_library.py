"""The library of standard cutters (`checker/resources/tools.toml`), validated on load.

Each `[[tool]]` gives `name`, `kind` (flat | ball | bullnose | apt | tapered_ball), `d` (APT
diameter), `r` (corner radius; a ball's defaults to d/2), optional `bottom_angle` / `taper_angle`
(degrees), `flute_length`, `length` (cutting length H; defaults to the flute length), optional
`shank_diameter`, `holder_diameter`, `holder_length`, `stickout`, and `units` ("mm" or "inch", the
unit of every length of that tool). Inside everything is mm and radians.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, model_validator

from checker.cutter import BALL_FAMILY, Cutter, diameter_from
from checker.errors import PathcheckError
from checker.resources import resource
from checker.toml_load import read_toml, validated
from checker.units import mm_per_unit

DEFAULT_TOOLS = resource("tools.toml")


class ToolSpec(BaseModel):
    """One `[[tool]]` entry as written in the file (its own units, degrees)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field(min_length=1)
    kind: Literal["flat", "ball", "bullnose", "apt", "tapered_ball"]
    units: Literal["mm", "inch"] = "mm"
    d: PositiveFloat
    r: float | None = Field(None, ge=0)
    bottom_angle: float = Field(0.0, ge=0, lt=90)
    taper_angle: float = Field(0.0, ge=0, lt=90)
    flute_length: PositiveFloat
    length: PositiveFloat | None = None
    shank_diameter: PositiveFloat | None = None
    holder_diameter: PositiveFloat | None = None
    holder_length: PositiveFloat | None = None
    stickout: PositiveFloat | None = None

    @model_validator(mode="after")
    def _geometry(self) -> ToolSpec:
        r = self.corner_radius
        angled = self.bottom_angle > 0.0 or self.taper_angle > 0.0
        if not angled and r > self.d / 2 * (1 + 1e-12):
            raise ValueError(f"corner radius r={r:g} is larger than half the diameter d={self.d:g}")
        if self.kind == "flat" and r != 0.0:
            raise ValueError(f"a flat end-mill has r = 0, found r={r:g}")
        if self.kind == "bullnose" and not 0.0 < r < self.d / 2:
            raise ValueError(f"a bull-nose end-mill needs 0 < r < d/2, found r={r:g}")
        if self.kind in ("flat", "ball", "bullnose") and (self.bottom_angle or self.taper_angle):
            raise ValueError(f"a {self.kind} end-mill has no bottom or taper angle")
        if self.kind == "tapered_ball" and self.taper_angle <= 0.0:
            raise ValueError("a tapered ball end-mill needs taper_angle > 0")
        if self.bottom_angle + self.taper_angle >= 90.0:
            raise ValueError("bottom_angle + taper_angle must be below 90 degrees")
        if self.kind in BALL_FAMILY:
            psi, th = math.radians(self.bottom_angle), math.radians(self.taper_angle)
            d_exp = diameter_from(0.0, r, psi, th)
            if abs(d_exp - self.d) > 1e-6 * self.d:
                raise ValueError(f"d={self.d:g} disagrees with r={r:g} (eq. 2.5 gives {d_exp:.6g})")
        elif self.radial_distance < 0.0:
            raise ValueError(f"r={r:g} leaves no room for the diameter d={self.d:g}")
        if self.length is not None and self.length < self.flute_length:
            raise ValueError("length must be >= flute_length")
        return self

    @property
    def corner_radius(self) -> float:
        if self.r is not None:
            return self.r
        if self.kind in BALL_FAMILY:
            psi, th = math.radians(self.bottom_angle), math.radians(self.taper_angle)
            return self.d / diameter_from(0.0, 1.0, psi, th)
        return 0.0

    @property
    def radial_distance(self) -> float:
        """R (tool's own units) from d by eq. 2.5; 0 for the ball family."""
        if self.kind in BALL_FAMILY:
            return 0.0
        psi, th = math.radians(self.bottom_angle), math.radians(self.taper_angle)
        return 0.5 * (self.d - diameter_from(0.0, self.corner_radius, psi, th))

    def to_cutter(self) -> Cutter:
        """The cutter in mm and radians."""
        k = mm_per_unit(self.units)

        def mm(v: float | None) -> float | None:
            return None if v is None else v * k

        return Cutter(
            kind=self.kind,
            d=self.d * k,
            r=self.corner_radius * k,
            R=max(self.radial_distance, 0.0) * k,
            psi=math.radians(self.bottom_angle),
            theta=math.radians(self.taper_angle),
            H=(self.length or self.flute_length) * k,
            flute_length=mm(self.flute_length),
            shank_diameter=mm(self.shank_diameter),
            holder_diameter=mm(self.holder_diameter),
            holder_length=mm(self.holder_length),
            stickout=mm(self.stickout),
            name=self.name,
        )


class ToolLibrary:
    """Validated standard cutters, by name and by family."""

    def __init__(self, tools: list[Cutter], path: Path | None = None) -> None:
        self.tools = list(tools)
        self.path = path
        self._by_name = {t.name: t for t in self.tools}

    def __len__(self) -> int:
        return len(self.tools)

    def __getitem__(self, name: str) -> Cutter:
        try:
            return self._by_name[name]
        except KeyError:
            raise PathcheckError(
                f"no tool named {name!r} in the tool library", path=self.path, code="tools"
            ) from None

    def family(
        self, kind_family: str, r: float | None = None, *, theta: float | None = None
    ) -> list[Cutter]:
        """Cutters of kind `kind_family`, ascending by size; `r` (mm) keeps the R families'
        cutters with that corner radius, `theta` (rad) those with that taper angle."""
        out = [t for t in self.tools if t.kind == kind_family]
        if r is not None and kind_family not in BALL_FAMILY:
            out = [t for t in out if abs(t.r - r) <= 1e-9 * max(1.0, r)]
        if theta is not None:
            out = [t for t in out if abs(t.theta - theta) <= 1e-9]
        return sorted(out, key=lambda t: t.size)

    def largest_not_exceeding(
        self, kind_family: str, size: float, r: float | None = None, *, theta: float | None = None
    ) -> Cutter | None:
        """The largest cutter of `family(kind_family, r, theta=theta)` whose size (R, or r for
        balls; mm) is <= `size`; None when every one is larger."""
        fam = self.family(kind_family, r, theta=theta)
        idx = largest_fitting(np.array([t.size for t in fam]), np.array([size]))[0]
        return None if idx < 0 else fam[idx]


def largest_fitting(sizes: np.ndarray, allowable: np.ndarray) -> np.ndarray:
    """The standard-cutter pick: (N,) index into the ascending standard sizes `sizes (K,)` (the
    allowable variable, mm) of the largest size not exceeding each allowable size `allowable
    (N,)` (mm; inf: unbounded, the largest fits; equal within 1e-12 relative and absolute
    counts as not exceeding), -1 where none fits or the allowable size is NaN (no answer)."""
    sizes = np.asarray(sizes, dtype=float)
    allowable = np.asarray(allowable, dtype=float)
    idx = np.searchsorted(sizes, allowable * (1 + 1e-12) + 1e-12, side="right") - 1
    return np.where(np.isnan(allowable), -1, idx)


def load_tool_library(path: str | Path | None = None) -> ToolLibrary:
    """Read and validate a tool library (default: the shipped one); a bad entry raises
    PathcheckError naming the tool and the field."""
    path = Path(path) if path is not None else DEFAULT_TOOLS
    data = read_toml(path, what="tool library", code="tools")
    extra = sorted(set(data) - {"tool"})
    if extra:
        raise PathcheckError(
            f"expected only [[tool]] tables, found {', '.join(extra)}", path=path, code="tools"
        )
    entries = data.get("tool", [])
    if not isinstance(entries, list) or not entries:
        raise PathcheckError("expected at least one [[tool]] table", path=path, code="tools")
    tools: list[Cutter] = []
    seen: set[str] = set()
    for i, raw in enumerate(entries, 1):
        label = raw.get("name", f"#{i}") if isinstance(raw, dict) else f"#{i}"
        spec = validated(ToolSpec, raw, subject=f"tool {label!r}", code="tools", path=path)
        if spec.name in seen:
            raise PathcheckError(f"tool {spec.name!r} is defined twice", path=path, code="tools")
        seen.add(spec.name)
        tools.append(spec.to_cutter())
    return ToolLibrary(tools, path)


def largest_standard(cutter: Cutter, size: float | None) -> str | None:
    """Name of the largest cutter of the shipped library in `cutter`'s family (same kind,
    corner radius and taper) whose size is at most `size` mm; None when none fits."""
    if size is None:
        return None
    r = cutter.family_corner
    best = load_tool_library().largest_not_exceeding(cutter.kind, size, r, theta=cutter.theta)
    return None if best is None else best.name
