"""The stock a CL file states, and where it stands against the part (part frame, mm).

SolidWorks CAM writes the stock's size and nothing of its place: `INSERT/Stock Size X135. Y135.
Z30.`. Its setup origin is a vertex of the stock's top face, so in the CL frame the stock's top
is at Z 0 and, with the origin at the top's low corner, the stock spans [0, X] x [0, Y] x
[-Z, 0]; its default stock is the part's bounding box with equal margins in X and Y, so it is
centred on the part there. The amorim SolidWorks CAM jobs (realdata) bear this out: on the three
whose STL is the part alone (Interface-glue, Sacrifice-Board, Teste-Metrologia) both rules give
the same box and the part lies inside it; the Z margins differ from job to job (1 mm on top
only, 2.5 mm on both faces, 10 mm on top only), so neither the part's top nor its bottom fixes
Z, while Z 0 is the top in all of them (and in RotateThin, whose cutting moves are centred on
[0, X] x [0, Y] and reach down to -Z). `place` therefore centres the stated stock on the part in
X and Y with its top at Z 0, and without a part puts its top's low corner at the origin; it says
when the part does not fit in the stock so placed (the stated size is then in another frame or
the part file holds more than the part, and the stock should be given)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from checker.toolpath import ToolPath

_NUMBER = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
_STOCK_SIZE = re.compile(
    rf"^\s*STOCK\s+SIZE\s*:?\s*X\s*=?\s*{_NUMBER}\s*,?\s*Y\s*=?\s*{_NUMBER}\s*,?\s*"
    rf"Z\s*=?\s*{_NUMBER}\s*$", re.IGNORECASE)
_FIT = 0.01  # mm the part may stand out of the placed stock and still fit (rounded sizes)
_INCH = 25.4


@dataclass(frozen=True, eq=False)
class StatedStock:
    """The stock's `size (3,)` mm along the part frame's X, Y, Z as the CL file states it, on
    1-based `line`."""

    size: np.ndarray
    line: int


def stated_stock(toolpath: ToolPath) -> StatedStock | None:
    """The first `INSERT/Stock Size X.. Y.. Z..` of the tool path with three positive sizes
    (converted to mm from the file's units), or None."""
    records = toolpath.records
    for record in getattr(records, "statements", records):
        if record.word != "INSERT" or not record.text:
            continue
        found = _STOCK_SIZE.match(record.text)
        if found is None:
            continue
        size = np.array([float(v) for v in found.groups()])
        if toolpath.units == "inch":
            size = size * _INCH
        if np.isfinite(size).all() and (size > 0).all():
            return StatedStock(size, int(record.line))
    return None


def _mm(v: float) -> str:
    return f"{round(float(v), 4) + 0.0:.6g}"  # to 0.1 um (a float32 part's 4e-7 is 0); no "-0"


def _extent(box: np.ndarray) -> str:
    return ", ".join(f"{a} {_mm(box[0, k])}..{_mm(box[1, k])}" for k, a in enumerate("XYZ"))


def place(stated: StatedStock, part_box: np.ndarray | None) -> tuple[np.ndarray, str]:
    """The stated stock as a box `(2, 3)` [min, max] corners in the part frame (mm) and one
    sentence saying how it was placed (the module docstring gives the rule). `part_box (2, 3)`
    the part's [min, max] corners, or None."""
    size = np.asarray(stated.size, float)
    said = f"stated stock {' x '.join(map(_mm, size))} mm (line {stated.line})"
    if part_box is None:
        box = np.array([[0.0, 0.0, -size[2]], [size[0], size[1], 0.0]])
        return box, f"{said}, its top's low corner at the origin: {_extent(box)}"
    pb = np.asarray(part_box, float).reshape(2, 3)
    centre = pb.mean(axis=0)
    fits_below_zero = pb[1, 2] <= _FIT and pb[0, 2] >= -size[2] - _FIT
    top = 0.0 if fits_below_zero else pb[1, 2]
    lo = np.array([centre[0] - size[0] / 2, centre[1] - size[1] / 2, top - size[2]])
    box = np.array([lo, lo + size])
    box[1, 2] = top
    how = (f"{said}, centred on the part in X and Y, top at "
           + ("Z 0 (the CL frame's origin)" if fits_below_zero else
              f"the part's top Z {_mm(top)} (the part stands above Z 0 or below Z "
              f"{_mm(-size[2])})") + f": {_extent(box)}")
    out = np.maximum(box[0] - pb[0], pb[1] - box[1])
    if (out > _FIT).any():
        k = int(np.argmax(out))
        how += (f"; the part does not fit in it (it stands {_mm(out[k])} mm out along "
                f"{'XYZ'[k]}): the stated size may be in another frame, or the part file "
                "hold more than the part; give the stock with --stock")
    return box, how
