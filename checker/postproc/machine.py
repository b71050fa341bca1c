"""Machine definitions as kinematic chains, read from TOML (`checker/resources/machines/NAME.toml`)
and validated by pydantic.

A machine is linear axes X, Y, Z (``[travel]``, the relative translation of the tool against the
table, ISO 841 signs) plus rotary axes (``[[rotary_axes]]``), each on the table or on the head:

- table axes are listed from the machine bed up to the part (the first carries the others); a
  positive word turns the part right-handed about ``direction`` through ``point`` (work frame,
  mm, at every rotary word 0);
- head axes are listed from the ram down to the spindle (the first carries the others); a
  positive word turns the tool right-handed about ``direction`` through ``point`` (mm, relative
  to the spindle gauge point at every rotary word 0: ``[0, 0, pivot_length]`` for a head whose
  axes cross the spindle line ``pivot_length`` above the gauge point).

The spindle is machine +Z (tip -> spindle). ``[head] tool_length`` is the gauge length used where
the control does not compensate it (head machines posted without tool-centre-point control).
``[setup]`` places the part frame (CL coordinates) on the table: work = ``rotation @ part +
origin``. Forward and inverse kinematics follow from the chain (`postproc.kinematics`), never from
the machine kind. Linear values mm in the work frame (G54), angles degrees.

The older 4-axis form (``[kinematics] table_center, b_direction`` with one ``[rotary]`` table) is
read as the B table it describes; ``machine.kinematics`` and ``machine.rotary`` still answer for
the first table axis (what the 4-axis planner asks).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    PositiveFloat,
    field_validator,
    model_validator,
)

from checker.errors import PathcheckError
from checker.postproc.components import Component, check_links
from checker.resources import resource
from checker.toml_load import read_toml, validated

MACHINES_DIR = resource("machines")
DEFAULT_MACHINE = "fanuc-hmc"

WrapMode = Literal["limited", "shortest", "0_360", "-180_180", "signed"]
Vec3 = tuple[float, float, float]


def _ordered(value: tuple[float, float]) -> tuple[float, float]:
    if value[1] <= value[0]:
        raise ValueError(f"max ({value[1]}) must be greater than min ({value[0]})")
    return value


Range = Annotated[tuple[float, float], AfterValidator(_ordered)]  # (min, max), min < max


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RotaryAxis(_Model):
    """One rotary axis of the chain. ``wrap`` says how words map to positions:

    - ``limited``: words in ``limits``, the axis moves by the difference of words;
    - ``0_360`` / ``-180_180``: continuous axis, words in that closed range, moved like
      ``limited`` (a cut crossing the range end is retracted, turned back a full turn and
      re-entered);
    - ``shortest``: rollover axis, words in ``[0, 360)``, the control takes the shorter way;
    - ``signed``: rollover axis, ``|word|`` in ``[0, 360)`` is the target, its sign the direction.

    A cut that turns the axis by more than ``max_turn_in_cut`` degrees is made as retract,
    rotate, re-enter (a comment says so in the program)."""

    name: Literal["A", "B", "C"]
    on: Literal["table", "head"] = "table"
    direction: Vec3
    point: Vec3 = (0.0, 0.0, 0.0)
    wrap: WrapMode = "limited"
    limits: Range = (-360.0, 360.0)
    max_feed: PositiveFloat = 3600.0  # deg/min
    max_turn_in_cut: PositiveFloat = 45.0

    @field_validator("direction")
    @classmethod
    def _unit(cls, value: Vec3) -> Vec3:
        norm = float(np.linalg.norm(value))
        if not np.isfinite(norm) or norm < 1e-9:
            raise ValueError("expected a non-zero direction vector [x, y, z]")
        return tuple(float(v) / norm for v in value)  # type: ignore[return-value]

    @property
    def b_min(self) -> float:
        return self.limits[0]

    @property
    def b_max(self) -> float:
        return self.limits[1]

    def word_range(self) -> tuple[float, float] | None:
        """Closed range of words for the modes that move by word difference; None for rollover."""
        return {
            "limited": self.limits,
            "0_360": (0.0, 360.0),
            "-180_180": (-180.0, 180.0),
        }.get(self.wrap)


class Travel(_Model):
    """The linear axes: travel of X, Y, Z in the work frame, mm (min, max)."""

    x: Range = (-500.0, 500.0)
    y: Range = (-500.0, 500.0)
    z: Range = (-500.0, 500.0)


class Feeds(_Model):
    """Feed limits and the feed mode of the posted program (G94: F scaled by the dialect's rule
    so the tip moves at the programmed feed; G93: inverse time, F = 1 / block time in minutes)."""

    max_linear: PositiveFloat = 20000.0  # mm/min
    rotary_mode: Literal["g94", "g93"] = "g94"


class Tcp(_Model):
    """Tool-centre-point control: with ``enabled`` the program carries part-frame (work-frame)
    tips and the axis angles, and the control does the kinematics (Fanuc G43.4, Siemens TRAORI,
    Heidenhain M128, LinuxCNC's TCP kinematics); without, the post computes machine X Y Z."""

    enabled: bool = False


class Head(_Model):
    """The spindle: tool gauge length (mm) used where the control does not compensate it."""

    tool_length: float = 0.0


class Setup(_Model):
    """Where the part frame sits on the table: work = ``rotation @ part + origin`` (rotation as
    three rows, a proper rotation matrix)."""

    rotation: tuple[Vec3, Vec3, Vec3] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    origin: Vec3 = (0.0, 0.0, 0.0)

    @field_validator("rotation")
    @classmethod
    def _proper(cls, value):
        r = np.asarray(value, dtype=float)
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise ValueError("expected a rotation matrix (orthonormal rows, determinant +1)")
        return value


_DECIMAL_INCREMENTS = {10.0**-k: k for k in range(7)}  # 1 ... 0.000001


class Format(_Model):
    """How numbers and blocks are written. The control's least input increments (its increment
    system, e.g. Fanuc IS-B: 0.001 mm, 0.0001 in, 0.001 deg): ``linear_increment`` mm for
    programs in mm, ``inch_increment`` in for programs in inches, ``rotary_increment`` deg;
    powers of ten, every word is rounded to them. Block numbers run from ``block_start`` by
    ``block_increment``; past ``block_max`` (the largest N the control takes) they start again
    at ``block_increment``. The older ``linear_decimals`` / ``rotary_decimals`` (digits after
    the point) are read as the increments they stand for."""

    block_numbers: bool = True
    block_start: int = Field(10, ge=0)
    block_increment: int = Field(10, ge=1)
    block_max: int = Field(99999, ge=1)
    linear_increment: float = 0.001
    inch_increment: float = 0.0001
    rotary_increment: float = 0.001
    feed_decimals: int = Field(1, ge=0, le=6)
    inverse_time_digits: int = Field(6, ge=3, le=10)  # significant digits of G93 F words
    program_number: int = Field(1000, ge=1, le=99999999)

    @model_validator(mode="before")
    @classmethod
    def _decimals(cls, data: Any) -> Any:
        if not isinstance(data, dict) or not {"linear_decimals", "rotary_decimals"} & set(data):
            return data
        data = dict(data)
        for old, new in (("linear_decimals", ("linear_increment", "inch_increment")),
                         ("rotary_decimals", ("rotary_increment",))):
            if old in data:
                digits = data.pop(old)
                if not isinstance(digits, int) or not 0 <= digits <= 6:
                    raise ValueError(f"{old} must be an integer 0..6, found {digits!r}")
                data.update({key: 10.0**-digits for key in new})
        return data

    @field_validator("linear_increment", "inch_increment", "rotary_increment")
    @classmethod
    def _power_of_ten(cls, value: float) -> float:
        for inc in _DECIMAL_INCREMENTS:
            if abs(value - inc) <= 1e-9 * inc:
                return inc
        raise ValueError("expected a power of ten from 1 to 0.000001, e.g. 0.001")

    @model_validator(mode="after")
    def _numbers(self) -> Format:
        if self.block_max < max(self.block_start, self.block_increment):
            raise ValueError(f"block_max ({self.block_max}) must be at least block_start "
                             f"({self.block_start}) and block_increment ({self.block_increment})")
        return self

    def linear_decimals(self, units: str) -> int:
        """Digits after the point of X Y Z words in a program in ``units`` ('mm' or 'inch')."""
        return _DECIMAL_INCREMENTS[self.inch_increment if units == "inch" else
                                   self.linear_increment]

    @property
    def rotary_decimals(self) -> int:
        """Digits after the point of rotary words."""
        return _DECIMAL_INCREMENTS[self.rotary_increment]


class Program(_Model):
    """Fixed program text and safe positions. ``tool_change`` lines may use ``{tool}``; None:
    the dialect's own lines (`checker.postproc.dialects`)."""

    header: list[str] | None = None
    footer: list[str] | None = None
    tool_change: list[str] | None = None
    safe_z: float = 200.0  # mm, work frame: retract plane along the spindle (machine +Z)
    reentry_clearance: PositiveFloat = 2.0  # mm above the re-entry point before feeding in

    @field_validator("header", "footer", "tool_change")
    @classmethod
    def _printable(cls, lines: list[str] | None) -> list[str] | None:
        for text in lines or ():
            if not all(" " <= c <= "~" for c in text):
                raise ValueError(f"expected printable ASCII G-code, found {text!r}")
        return lines


class Kinematics(_Model):
    """The 4-axis view of a machine (docs/MATH.md §1): a point on the first table axis in the part
    frame, and +1 / -1 as that axis turns the part about +Y / -Y."""

    table_center: Vec3 = (0.0, 0.0, 0.0)
    b_direction: Literal[1, -1] = 1


def _legacy(data: dict[str, Any]) -> dict[str, Any]:
    """The older 4-axis form (``[kinematics]`` + one ``[rotary]`` table) as a chain."""
    kin = data.pop("kinematics", {}) or {}
    rot = data.pop("rotary", {}) or {}
    if not isinstance(kin, dict) or not isinstance(rot, dict):
        raise ValueError("expected [kinematics] and [rotary] tables (or [[rotary_axes]])")
    unknown = (set(kin) - {"table_center", "b_direction"}) | (
        set(rot) - {"wrap", "b_min", "b_max", "max_feed", "max_turn_in_cut"}
    )
    if unknown:
        raise ValueError(f"unknown 4-axis field(s) {sorted(unknown)}")
    direction = kin.get("b_direction", 1)
    if direction not in (1, -1):
        raise ValueError(f"kinematics.b_direction must be 1 or -1, found {direction!r}")
    axis = {
        "name": "B",
        "on": "table",
        "direction": [0.0, float(direction), 0.0],
        "point": kin.get("table_center", [0.0, 0.0, 0.0]),
        "wrap": rot.get("wrap", "shortest"),
        "limits": [rot.get("b_min", -360.0), rot.get("b_max", 360.0)],
    }
    for key in ("max_feed", "max_turn_in_cut"):
        if key in rot:
            axis[key] = rot[key]
    data["rotary_axes"] = [axis]
    return data


class Machine(_Model):
    """A machine: linear axes X Y Z, a chain of rotary axes on the table and the head, its
    control's dialect and the posting options."""

    name: str
    description: str = ""
    dialect: Literal["fanuc", "linuxcnc", "siemens", "heidenhain", "haas", "millplus"] = "fanuc"
    units: Literal["mm", "inch"] = "mm"
    rotary_axes: tuple[RotaryAxis, ...] = ()
    travel: Travel = Travel()
    feeds: Feeds = Feeds()
    tcp: Tcp = Tcp()
    head: Head = Head()
    setup: Setup = Setup()
    format: Format = Format()
    program: Program = Program()
    components: tuple[Component, ...] = ()  # the machine's solids (`checker.postproc.components`)
    components_source: str = ""  # where their dimensions come from ("generic" when made up)

    @model_validator(mode="before")
    @classmethod
    def _older_form(cls, data: Any) -> Any:
        if isinstance(data, dict) and ("kinematics" in data or "rotary" in data):
            if "rotary_axes" in data:
                raise ValueError("give either [[rotary_axes]] or [kinematics]/[rotary], not both")
            return _legacy(dict(data))
        return data

    @model_validator(mode="after")
    def _consistent(self) -> Machine:
        lo, hi = self.travel.z
        if not lo <= self.program.safe_z <= hi:
            raise ValueError(
                f"program.safe_z ({self.program.safe_z}) outside travel.z {self.travel.z}"
            )
        names = [a.name for a in self.rotary_axes]
        if len(set(names)) != len(names):
            raise ValueError(f"rotary axis names must differ, found {names}")
        if len(names) > 3:
            raise ValueError(f"at most 3 rotary axes, found {len(names)}")
        if self.feeds.rotary_mode == "g93" and self.dialect in ("heidenhain", "millplus"):
            raise ValueError(f"the {self.dialect} dialect has no inverse-time feed (G93)")
        check_links(self.components, [a.name for a in self.rotary_axes if a.on == "table"],
                    [a.name for a in self.rotary_axes if a.on == "head"])
        return self

    # -- views ------------------------------------------------------------------------------
    @property
    def kind(self) -> str:
        """A short name of the chain, e.g. ``table-table A/C``, ``head-table B/C``, ``table B``."""
        table = [a.name for a in self.rotary_axes if a.on == "table"]
        head = [a.name for a in self.rotary_axes if a.on == "head"]
        if not table and not head:
            return "3-axis"
        parts = ["head"] * len(head) + ["table"] * len(table)
        return "-".join(parts) + " " + "/".join(head + table)

    @property
    def rotary(self) -> RotaryAxis:
        """The first table axis (else the first axis): what the 4-axis B planner asks."""
        if not self.rotary_axes:
            return RotaryAxis(name="B", direction=(0.0, 1.0, 0.0), wrap="limited")
        tables = [a for a in self.rotary_axes if a.on == "table"]
        return (tables or list(self.rotary_axes))[0]

    @property
    def kinematics(self) -> Kinematics:
        """The first table axis as the docs/MATH.md §1 B table: a point on it in the part frame and
        the sign of its turn about +Y (1 unless it turns the part about -Y)."""
        axis = self.rotary
        rot = np.asarray(self.setup.rotation, dtype=float)
        center = rot.T @ (np.asarray(axis.point) - np.asarray(self.setup.origin))
        part_dir = rot.T @ np.asarray(axis.direction)
        sign = -1 if part_dir[1] < 0 else 1
        return Kinematics(table_center=tuple(float(v) for v in center), b_direction=sign)

    def with_dialect(self, dialect: str) -> Machine:
        """A copy for another control: the dialect, its program text, and its feed mode where it
        has no inverse time."""
        from checker.postproc.dialects import get_dialect

        mode = self.feeds.rotary_mode if get_dialect(dialect).inverse_time else "g94"
        return self.with_options(
            dialect=dialect, feeds={"rotary_mode": mode},
            program={"header": None, "footer": None, "tool_change": None},
        )

    def with_options(self, **update) -> Machine:
        """A copy with sections or fields replaced and validated again, e.g.
        ``with_options(dialect="siemens", tcp={"enabled": True})``; a dict merges into its
        section, ``rotary_axes`` takes a list of dicts merged into the axes in order."""
        data = self.model_dump()
        for key, value in update.items():
            if key == "rotary_axes" and isinstance(value, list | tuple):
                data[key] = [
                    {**old, **(new or {})}
                    for old, new in zip(data[key], list(value) + [None] * len(data[key]),
                                        strict=False)
                ]
            elif isinstance(value, dict) and isinstance(data.get(key), dict):
                data[key] = {**data[key], **value}
            else:
                data[key] = value
        return validated(Machine, data, subject="machine", code="machine")


def load_machine_file(path: str | Path) -> Machine:
    """Read and validate one machine TOML file; an invalid field is named in the error."""
    path = Path(path)
    data = read_toml(path, what="machine file", code="machine")
    data.setdefault("name", path.stem)
    for comp in data.get("components") or ():  # a mesh beside the machine file
        if isinstance(comp, dict) and isinstance(comp.get("mesh"), str):
            comp["mesh"] = str(path.parent / comp["mesh"])
    return validated(Machine, data, subject="machine", code="machine", path=path)


def available_machines() -> list[str]:
    """Names of the shipped machines."""
    return sorted(p.stem for p in MACHINES_DIR.glob("*.toml"))


def load_machine(name_or_path: str | Path | None = None) -> Machine:
    """A machine by name (a shipped one, ``checker/resources/machines/NAME.toml``) or by file
    path; the default machine (``fanuc-hmc``) when None."""
    target = DEFAULT_MACHINE if name_or_path is None else str(name_or_path)
    candidate = Path(target)
    if candidate.suffix == ".toml" or candidate.exists():
        return load_machine_file(candidate)
    path = MACHINES_DIR / f"{target}.toml"
    if not path.is_file():
        raise PathcheckError(
            f"unknown machine '{target}': expected one of {', '.join(available_machines())} "
            "or a path to a .toml file",
            code="machine",
        )
    return load_machine_file(path)
