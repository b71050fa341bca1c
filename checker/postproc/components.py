"""The machine's own solids (`[[components]]` of a machine TOML): each a primitive (an axis-aligned
box, a cylinder, a cone frustum) or a mesh (STL beside the machine file), attached to a link of
the kinematic chain (`postproc.machine`), for the check of the machine against itself, the tool
and the work (`checker.collide`, docs/MATH.md §16).

Links and their frames (mm, at every rotary word 0):

- ``bed`` (the table's base) and each *table* axis (by name: ``A``, ``B``, ``C``): given in the
  work frame; a table axis's component turns with that axis and the axes that carry it. ``moves``
  (default none) names the linear axes that move a component of the bed relative to the table:
  a column on a machine whose table travels in X and Y moves with ``"xy"``;
- ``ram`` (the spindle carrier before any head axis), each *head* axis and ``spindle``: given in
  the spindle frame, origin at the spindle nose (the gauge point), +Z up the spindle; they move
  with X, Y and Z and turn with the head axes that carry them (``spindle``: all of them).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, PositiveFloat, field_validator, model_validator

Vec3 = tuple[float, float, float]
HEAD_LINKS = ("ram", "spindle")


class Cylinder(BaseModel):
    """A cylinder of `radius` from `start` to `end` (link frame, mm)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    radius: PositiveFloat
    start: Vec3
    end: Vec3

    @model_validator(mode="after")
    def _long(self) -> Cylinder:
        if np.linalg.norm(np.subtract(self.end, self.start)) < 1e-9:
            raise ValueError("expected start and end apart")
        return self


class Cone(BaseModel):
    """A cone frustum: radius `radius_start` at `start`, `radius_end` at `end` (mm; 0: a point)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    radius_start: float
    radius_end: float
    start: Vec3
    end: Vec3

    @model_validator(mode="after")
    def _shape(self) -> Cone:
        if min(self.radius_start, self.radius_end) < 0 or max(self.radius_start,
                                                               self.radius_end) <= 0:
            raise ValueError("expected radii >= 0, one of them > 0")
        if np.linalg.norm(np.subtract(self.end, self.start)) < 1e-9:
            raise ValueError("expected start and end apart")
        return self


class Box(BaseModel):
    """An axis-aligned box (link frame) from corner `min` to corner `max` (mm)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    min: Vec3
    max: Vec3

    @model_validator(mode="after")
    def _ordered(self) -> Box:
        if not all(b > a for a, b in zip(self.min, self.max, strict=True)):
            raise ValueError(f"expected max {list(self.max)} above min {list(self.min)} "
                             "on every axis")
        return self


class Component(BaseModel):
    """One solid of the machine: its `name`, the `link` it is attached to (module docstring),
    the linear axes that move it (`moves`, None: the link's default) and exactly one shape:
    `box`, `cylinder`, `cone` or `mesh` (an STL file, relative to the machine file)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    name: str
    link: str
    moves: str | None = None
    box: Box | None = None
    cylinder: Cylinder | None = None
    cone: Cone | None = None
    mesh: str | None = None

    @field_validator("moves")
    @classmethod
    def _axes(cls, value: str | None) -> str | None:
        if value is not None and (set(value.lower()) - set("xyz")):
            raise ValueError(f"expected linear axes from 'xyz', found {value!r}")
        return None if value is None else value.lower()

    @model_validator(mode="after")
    def _one_shape(self) -> Component:
        given = [k for k in ("box", "cylinder", "cone", "mesh") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"component '{self.name}': expected exactly one of box, cylinder, "
                             f"cone, mesh, found {given or 'none'}")
        return self

    @property
    def shape(self) -> Literal["box", "cylinder", "cone", "mesh"]:
        return next(k for k in ("box", "cylinder", "cone", "mesh")  # type: ignore[return-value]
                    if getattr(self, k) is not None)


def check_links(components, table: list[str], head: list[str]) -> None:
    """ValueError naming a component whose link is not one of the chain's, or a component off the
    bed that names `moves`."""
    known = ["bed", *table, "ram", *head, "spindle"]
    names = [c.name for c in components]
    if len(set(names)) != len(names):
        raise ValueError(f"component names must differ, found {names}")
    for c in components:
        if c.link not in known:
            raise ValueError(f"component '{c.name}': link '{c.link}', expected one of "
                             f"{', '.join(known)}")
        if c.moves is not None and c.link != "bed":
            raise ValueError(f"component '{c.name}': `moves` is for components of the bed")
