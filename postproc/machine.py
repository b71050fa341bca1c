"""Machine definitions: a horizontal 4-axis machining centre with a B table about machine Y,
read from TOML (`checker/resources/machines/NAME.toml`) and validated by pydantic.

Frames and units: linear values in mm in the program's work frame (G54); B in degrees. Commanding
``B = w`` turns the part by ``b = b_direction * w`` about +Y through ``table_center`` (DESIGN.md).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PositiveFloat,
    ValidationError,
    field_validator,
    model_validator,
)

from checker.errors import PathcheckError
from checker.resources import resource

MACHINES_DIR = resource("machines")
DEFAULT_MACHINE = "fanuc-hmc"

WrapMode = Literal["limited", "shortest", "0_360", "-180_180", "signed"]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Kinematics(_Model):
    """Where the B axis is and which way it counts."""

    table_center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    b_direction: Literal[1, -1] = 1


class Rotary(_Model):
    """The B axis. ``wrap`` says how B words map to table positions:

    - ``limited``: words in ``[b_min, b_max]``, the table moves by the difference of words;
    - ``0_360`` / ``-180_180``: continuous table, words in that closed range, moved like ``limited``
      (a cut crossing the range end is retracted, rotated back a full turn and re-entered);
    - a cut that turns B by more than ``max_turn_in_cut`` degrees is not cut with the table
      turning: the post retracts, turns the table and re-enters at the end point (a comment says
      so in the program).
    - ``shortest``: rollover axis, words in ``[0, 360)``, the control takes the shorter way;
    - ``signed``: rollover axis, ``|word|`` in ``[0, 360)`` is the target, its sign the direction.
    """

    wrap: WrapMode = "shortest"
    b_min: float = -360.0
    b_max: float = 360.0
    max_feed: PositiveFloat = 3600.0  # deg/min
    max_turn_in_cut: PositiveFloat = 45.0  # deg: a cut turning more is retract-rotate-re-enter

    @model_validator(mode="after")
    def _range(self) -> Rotary:
        if self.b_max <= self.b_min:
            raise ValueError(f"b_max ({self.b_max}) must be greater than b_min ({self.b_min})")
        return self

    def word_range(self) -> tuple[float, float] | None:
        """Closed range of B words for the modes that move by word difference; None for rollover."""
        return {
            "limited": (self.b_min, self.b_max),
            "0_360": (0.0, 360.0),
            "-180_180": (-180.0, 180.0),
        }.get(self.wrap)


class Travel(_Model):
    """Travel limits of X, Y, Z in the work frame, mm (min, max)."""

    x: tuple[float, float] = (-500.0, 500.0)
    y: tuple[float, float] = (-500.0, 500.0)
    z: tuple[float, float] = (-500.0, 500.0)

    @field_validator("x", "y", "z")
    @classmethod
    def _ordered(cls, value: tuple[float, float]) -> tuple[float, float]:
        if value[1] <= value[0]:
            raise ValueError(f"max ({value[1]}) must be greater than min ({value[0]})")
        return value


class Feeds(_Model):
    """Feed limits and the rotary feed mode (G94: F scaled by the dialect's rotary rule so the tip
    moves at the programmed feed; G93: inverse time, F = 1 / block time in minutes)."""

    max_linear: PositiveFloat = 20000.0  # mm/min
    rotary_mode: Literal["g94", "g93"] = "g94"


class Format(_Model):
    """How numbers and blocks are written."""

    block_numbers: bool = True
    block_start: int = Field(10, ge=0)
    block_increment: int = Field(10, ge=1)
    linear_decimals: int = Field(4, ge=0, le=6)
    rotary_decimals: int = Field(5, ge=0, le=6)
    feed_decimals: int = Field(1, ge=0, le=6)
    inverse_time_digits: int = Field(6, ge=3, le=10)  # significant digits of G93 F words
    program_number: int = Field(1000, ge=1, le=99999999)


class Program(_Model):
    """Fixed program text and safe positions. ``tool_change`` lines may use ``{tool}``."""

    header: list[str] = ["G17 G40 G49 G80 G90", "G54"]
    footer: list[str] = ["M05", "M09", "M30"]
    tool_change: list[str] = ["T{tool} M06"]
    safe_z: float = 200.0  # mm, work frame: retract plane along the spindle (machine +Z)
    reentry_clearance: PositiveFloat = 2.0  # mm above the re-entry point before feeding in

    @field_validator("header", "footer", "tool_change")
    @classmethod
    def _printable(cls, lines: list[str]) -> list[str]:
        for text in lines:
            if not all(" " <= c <= "~" for c in text):
                raise ValueError(f"expected printable ASCII G-code, found {text!r}")
        return lines


class Machine(_Model):
    """A horizontal 4-axis machine: spindle along machine +Z, B table about machine Y."""

    name: str
    description: str = ""
    dialect: Literal["fanuc", "linuxcnc"] = "fanuc"
    units: Literal["mm", "inch"] = "mm"
    kinematics: Kinematics = Kinematics()
    rotary: Rotary = Rotary()
    travel: Travel = Travel()
    feeds: Feeds = Feeds()
    format: Format = Format()
    program: Program = Program()

    @model_validator(mode="after")
    def _safe_z(self) -> Machine:
        lo, hi = self.travel.z
        if not lo <= self.program.safe_z <= hi:
            raise ValueError(
                f"program.safe_z ({self.program.safe_z}) outside travel.z {self.travel.z}"
            )
        return self


def load_machine_file(path: str | Path) -> Machine:
    """Read and validate one machine TOML file; an invalid field is named in the error."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except OSError as err:
        raise PathcheckError(
            f"cannot read machine file: {err.strerror}", path=path, code="machine"
        ) from err
    except tomllib.TOMLDecodeError as err:
        raise PathcheckError(
            f"machine file is not valid TOML: {err}", path=path, code="machine"
        ) from err
    data.setdefault("name", path.stem)
    try:
        return Machine.model_validate(data)
    except ValidationError as err:
        first = err.errors()[0]
        field = ".".join(str(p) for p in first["loc"]) or "(file)"
        found = first.get("input")
        shown = "" if isinstance(found, dict) else f", found {found!r}"
        raise PathcheckError(
            f"machine field '{field}': {first['msg']}{shown}", path=path, code="machine"
        ) from err


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
