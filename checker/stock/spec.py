"""The `--stock` text: a shape in the part frame (mm), parsed, then resolved against the part's
bounding box or the stock the CL file states (docs/MATH.md §14).

Grammar (numbers are decimals; spaces around them are ignored; keywords and axes in any case)::

    box:+M                              a margin M >= 0 around the part's bounding box, every side
    box:+MX,+MY,+MZ                     margins per axis (both sides of that axis)
    box:+XMIN,+XMAX,+YMIN,+YMAX,+ZMIN,+ZMAX   margins per side
    box:X0,Y0,Z0,X1,Y1,Z1               the corners (no '+'; X1 > X0, Y1 > Y0, Z1 > Z0)
    cylinder:AXIS:+M                    bar stock about the axis AXIS (x, y or z) through the
                                        origin: radius = the part's largest distance from the axis
                                        + M, length = the part's extent along it + M at each end
    cylinder:AXIS:D,START,END           diameter D > 0, from START to END > START along the axis
    cylinder:AXIS@C1,C2:...             the axis line through (C1, C2): the other two coordinates
                                        in x, y, z order (AXIS x: y, z; y: x, z; z: x, y)
    PATH.stl | .step | .stp | .igs | .iges   a solid read from the file (it must exist)
    cl                                  the stock the CL file states (`checker.stock.stated`)

A margin form needs the part; `cl` needs a CL file that states its stock."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError, printable
from checker.stock.stated import StatedStock, place

AXES = "xyz"
SOLID_SUFFIXES = (".stl", ".step", ".stp", ".igs", ".iges")


# ---- the parsed text ----------------------------------------------------------------------

@dataclass(frozen=True)
class BoxMargins:
    """A box around the part's bounding box: `low` the margins below (x, y, z min sides) and
    `high` above (x, y, z max sides), mm >= 0."""

    low: tuple[float, float, float]
    high: tuple[float, float, float]


@dataclass(frozen=True)
class BoxCorners:
    """A box by its corners `low` < `high` (x, y, z), mm."""

    low: tuple[float, float, float]
    high: tuple[float, float, float]


@dataclass(frozen=True)
class CylinderMargin:
    """Bar stock about the part-frame `axis` ('x', 'y', 'z') through `centre` (the other two
    coordinates in x, y, z order, mm) around the part with the radial and end margin `margin`."""

    axis: str
    centre: tuple[float, float]
    margin: float


@dataclass(frozen=True)
class CylinderGiven:
    """Bar stock about `axis` through `centre`: `diameter`, from `start` to `end` along it, mm."""

    axis: str
    centre: tuple[float, float]
    diameter: float
    start: float
    end: float


@dataclass(frozen=True)
class SolidPath:
    """A solid stock read from `path` (STL, STEP or IGES)."""

    path: Path


@dataclass(frozen=True)
class FromCL:
    """The stock the CL file states."""


StockSpec = BoxMargins | BoxCorners | CylinderMargin | CylinderGiven | SolidPath | FromCL


# ---- the resolved shape ---------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Box:
    """An axis-aligned box from `lo (3,)` to `hi (3,)`, part frame, mm; `how` one sentence
    saying where it came from."""

    lo: np.ndarray
    hi: np.ndarray
    how: str = ""


@dataclass(frozen=True, eq=False)
class Cylinder:
    """A cylinder about the part-frame `axis` ('x', 'y', 'z') through `centre (2,)` (the other
    two coordinates in x, y, z order), `radius`, from `start` to `end` along the axis, mm."""

    axis: str
    centre: np.ndarray
    radius: float
    start: float
    end: float
    how: str = ""

    @property
    def others(self) -> tuple[int, int]:
        """The indices of the two coordinates `centre` holds."""
        k = AXES.index(self.axis)
        return tuple(i for i in range(3) if i != k)  # type: ignore[return-value]


@dataclass(frozen=True, eq=False)
class SolidFile:
    """A solid stock to be read from `path` (`checker.stock.solid.load_solid`)."""

    path: Path
    how: str = ""


Stock = Box | Cylinder | SolidFile


def _fail(text: str, expected: str) -> PathcheckError:
    return PathcheckError(f"--stock '{printable(text)}': expected {expected}", code="usage")


_BOX = ("box:+M, box:+MX,+MY,+MZ, box:+XMIN,+XMAX,+YMIN,+YMAX,+ZMIN,+ZMAX (margins >= 0) "
        "or box:X0,Y0,Z0,X1,Y1,Z1 (corners)")
_CYL = "cylinder:AXIS[@C1,C2]:+M or cylinder:AXIS[@C1,C2]:D,START,END with AXIS x, y or z"
_ANY = (f"{_BOX}, {_CYL}, a solid file ({', '.join(SOLID_SUFFIXES)}) or cl (the stock the CL "
        "file states)")


def _numbers(text: str, part: str, expected: str) -> tuple[list[float], list[bool]]:
    """The comma-separated numbers of `part` and whether each had a leading '+'."""
    values, plus = [], []
    for item in part.split(","):
        item = item.strip()
        signed = item.startswith("+")
        try:
            v = float(item[1:] if signed else item)
        except ValueError:
            raise _fail(text, f"{expected}; '{printable(item)}' is not a number") from None
        if not math.isfinite(v):
            raise _fail(text, f"{expected}; '{printable(item)}' is not a finite number")
        values.append(v)
        plus.append(signed)
    return values, plus


def _margins(text: str, values: list[float], expected: str) -> list[float]:
    if min(values) < 0.0:
        raise _fail(text, f"{expected}; a margin is >= 0, found {min(values):g}")
    return values


def solid_name(text: str) -> str | None:
    """The file name when the stock text names a solid (an STL, STEP or IGES file, whether or
    not it exists), else None: a caller that reads files through its own gate (the service's
    roots) resolves it before `parse_stock` looks for it."""
    body = text.strip()
    kind, colon, _ = body.partition(":")
    if body.lower() == "cl" or (colon and kind.strip().lower() in ("box", "cylinder")):
        return None
    return body if body.lower().endswith(SOLID_SUFFIXES) else None


def parse_stock(text: str) -> StockSpec:
    """The stock the text names (grammar in the module docstring); PathcheckError(code="usage")
    naming the text and what was expected."""
    body = text.strip()
    kind, colon, rest = body.partition(":")
    kind = kind.strip().lower()
    if body.lower() == "cl":
        return FromCL()
    if colon and kind == "box":
        return _box(text, rest)
    if colon and kind == "cylinder":
        return _cylinder(text, rest)
    if solid_name(body) is not None:
        path = Path(body)
        if not path.is_file():
            raise PathcheckError(f"--stock: the solid file '{printable(body)}' does not exist "
                                 "(expected an STL, STEP or IGES file)", code="usage")
        return SolidPath(path)
    raise _fail(text, _ANY)


def _box(text: str, rest: str) -> StockSpec:
    values, plus = _numbers(text, rest, _BOX)
    if all(plus) and len(values) in (1, 3, 6):
        m = _margins(text, values, _BOX)
        if len(m) == 1:
            return BoxMargins((m[0],) * 3, (m[0],) * 3)
        if len(m) == 3:
            return BoxMargins(tuple(m), tuple(m))  # type: ignore[arg-type]
        return BoxMargins((m[0], m[2], m[4]), (m[1], m[3], m[5]))
    if not any(plus) and len(values) == 6:
        lo, hi = values[:3], values[3:]
        bad = [a for a, x0, x1 in zip(AXES, lo, hi, strict=True) if not x1 > x0]
        if bad:
            raise _fail(text, f"{_BOX}; the corners' {bad[0].upper()}1 must be greater than "
                              f"{bad[0].upper()}0")
        return BoxCorners(tuple(lo), tuple(hi))  # type: ignore[arg-type]
    if any(plus) and not all(plus):
        raise _fail(text, f"{_BOX}; margins ('+') and corners cannot be mixed")
    raise _fail(text, f"{_BOX}; found {len(values)} number(s)")


def _cylinder(text: str, rest: str) -> StockSpec:
    head, colon, numbers = rest.partition(":")
    axis, at, where = head.partition("@")
    axis = axis.strip().lower()
    if not colon or axis not in ("x", "y", "z"):
        raise _fail(text, _CYL)
    centre = (0.0, 0.0)
    if at:
        c, plus = _numbers(text, where, _CYL + " (@C1,C2: the axis line's other two coordinates)")
        if len(c) != 2 or any(plus):
            raise _fail(text, f"{_CYL}; @C1,C2 is two numbers, the axis line's other two "
                              "coordinates in x, y, z order")
        centre = (c[0], c[1])
    values, plus = _numbers(text, numbers, _CYL)
    if len(values) == 1 and plus[0]:
        return CylinderMargin(axis, centre, _margins(text, values, _CYL)[0])
    if len(values) == 3 and not any(plus):
        d, start, end = values
        if not d > 0.0:
            raise _fail(text, f"{_CYL}; the diameter D must be > 0, found {d:g}")
        if not end > start:
            raise _fail(text, f"{_CYL}; END must be greater than START")
        return CylinderGiven(axis, centre, d, start, end)
    raise _fail(text, _CYL)


def _mm(v: float) -> str:
    return f"{v:.6g}"


def resolve(spec: StockSpec, part_box: np.ndarray | None, stated: StatedStock | None, *,
            part_points: np.ndarray | None = None) -> Stock:
    """The stock shape of `spec` in the part frame: margins applied to `part_box (2, 3)` (the
    part's [min, max] corners, mm), `cl` placed by `stated.place`. `part_points (N, 3)` (the
    part's vertices, optional) give a cylinder margin's radius exactly; without them the
    bounding box's corners do (larger or equal). A margin form without a part, or `cl` without a
    stated stock: PathcheckError(code="usage") saying what is missing."""
    if isinstance(spec, BoxCorners):
        lo, hi = np.array(spec.low, float), np.array(spec.high, float)
        return Box(lo, hi, f"box from ({', '.join(map(_mm, lo))}) to ({', '.join(map(_mm, hi))})")
    if isinstance(spec, SolidPath):
        return SolidFile(spec.path, f"the solid in {spec.path}")
    if isinstance(spec, CylinderGiven):
        return Cylinder(spec.axis, np.array(spec.centre, float), spec.diameter / 2.0, spec.start,
                        spec.end, f"cylinder about {spec.axis.upper()} through "
                        f"({_mm(spec.centre[0])}, {_mm(spec.centre[1])}), diameter "
                        f"{_mm(spec.diameter)} from {_mm(spec.start)} to {_mm(spec.end)}")
    if isinstance(spec, FromCL):
        if stated is None:
            raise PathcheckError("--stock cl: the CL file states no stock (expected an "
                                 "'INSERT/Stock Size X.. Y.. Z..' record); give the stock as "
                                 "box:..., cylinder:... or a solid file", code="usage")
        box, how = place(stated, part_box)
        return Box(box[0], box[1], how)
    if part_box is None:
        raise PathcheckError("--stock: a margin around the part needs the part (give --part, or "
                             "the stock by its corners: box:X0,Y0,Z0,X1,Y1,Z1 or "
                             "cylinder:AXIS:D,START,END)", code="usage")
    pb = np.asarray(part_box, float).reshape(2, 3)
    if isinstance(spec, BoxMargins):
        lo, hi = pb[0] - spec.low, pb[1] + spec.high
        if not (hi > lo).all():
            raise PathcheckError("--stock box:+...: the part is flat and its margin 0 along "
                                 f"{AXES[int(np.argmin(hi - lo))].upper()}: expected a margin "
                                 "> 0 there", code="usage")
        return Box(lo, hi, f"box from ({', '.join(map(_mm, lo))}) to ({', '.join(map(_mm, hi))})"
                   f", the part's bounding box with margins -({', '.join(map(_mm, spec.low))}) "
                   f"+({', '.join(map(_mm, spec.high))})")
    k = AXES.index(spec.axis)
    others = [i for i in range(3) if i != k]
    if part_points is not None and len(part_points):
        pts = np.asarray(part_points, float).reshape(-1, 3)[:, others]
    else:  # the bounding box's corners in the plane across the axis
        pts = np.array([[pb[a, others[0]], pb[b, others[1]]] for a in (0, 1) for b in (0, 1)])
    radius = float(np.hypot(*(pts - np.asarray(spec.centre)).T).max()) + spec.margin
    start, end = pb[0, k] - spec.margin, pb[1, k] + spec.margin
    if not (radius > 0.0 and end > start):
        raise PathcheckError(f"--stock cylinder:{spec.axis}:+{_mm(spec.margin)}: the part lies "
                             "on the axis or is flat across it, and the margin is 0: expected a "
                             "margin > 0", code="usage")
    return Cylinder(spec.axis, np.array(spec.centre, float), radius, float(start), float(end),
                    f"cylinder about {spec.axis.upper()} through ({_mm(spec.centre[0])}, "
                    f"{_mm(spec.centre[1])}), radius {_mm(radius)} (the part's farthest point "
                    f"+ {_mm(spec.margin)}) from {_mm(start)} to {_mm(end)}")
