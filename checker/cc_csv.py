"""CC points from a CSV file with the header x,y,z,nx,ny,nz (part frame, mm): the one reader of
`pathcheck allowable --cc` and `pathcheck call --cc`; errors name the file and line."""

from __future__ import annotations

import math
import re
from array import array
from pathlib import Path

import numpy as np

from checker import input_limits
from checker.cc_points import Rows, unit_normals
from checker.errors import PathcheckError

CC_COLUMNS = ("x", "y", "z", "nx", "ny", "nz")
# a decimal number as a CSV writes it (Python's float() also takes 1_0, nan, infinity: not these)
_NUMBER = re.compile(r"\s*[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\s*")


def read_cc_csv(path: Path, *, lines_out: list[int] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """CC points (N, 3) and unit normals (N, 3) from a CSV with the header x,y,z,nx,ny,nz;
    `lines_out` receives each row's 1-based file line. More than `MAX_CC_POINTS` rows is an
    error naming the first row beyond."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise PathcheckError(f"cannot read CC file: {err}", path=path, code="input") from err
    if not lines:
        raise PathcheckError("empty CC file, expected a header x,y,z,nx,ny,nz", path=path, line=1)
    head = [h.strip().lower() for h in lines[0].removeprefix("\ufeff").split(",")]
    if head != list(CC_COLUMNS):
        raise PathcheckError(f"expected the header x,y,z,nx,ny,nz, found {lines[0][:60]!r}",
                             path=path, line=1)
    count = sum(1 for text in lines[1:] if text.strip())
    if count > input_limits.MAX_CC_POINTS:
        beyond = [no for no, text in enumerate(lines[1:], 2) if text.strip()]
        input_limits.refuse_beyond(count, input_limits.MAX_CC_POINTS, "CC points",
                                   "MAX_CC_POINTS", path=path,
                                   line=beyond[input_limits.MAX_CC_POINTS])
    rows = array("d")  # 6 values a row, 48 bytes (a list of floats per row takes 260)
    numbers = array("q")  # each row's line
    for no, text in enumerate(lines[1:], 2):
        if not text.strip():
            continue
        cells = text.split(",")
        if len(cells) != 6:
            raise PathcheckError(f"expected 6 values, found {len(cells)}", path=path, line=no)
        bad = [c.strip() for c in cells if not _NUMBER.fullmatch(c)]
        if bad:
            raise PathcheckError(f"expected 6 decimal numbers, found {bad[0][:30]!r} in "
                                 f"{text.strip()[:60]!r}", path=path, line=no)
        vals = [float(c) for c in cells]
        if not all(map(math.isfinite, vals)):
            raise PathcheckError(f"expected finite numbers, found {text.strip()[:60]!r}",
                                 path=path, line=no)
        rows.extend(vals)
        numbers.append(no)
    if not rows:
        raise PathcheckError("expected at least one CC point after the header", path=path, line=2)
    if lines_out is not None:
        lines_out.extend(numbers)
    a = np.frombuffer(rows, dtype=float).reshape(-1, 6)
    return a[:, :3], unit_normals(a[:, 3:], Rows(path, numbers))


def cc_rows(path: Path) -> list[list[float]]:
    """The rows x,y,z,nx,ny,nz of `read_cc_csv` (normals unit), as the service's `cc` field."""
    cc, normals = read_cc_csv(path)
    return np.hstack([cc, normals]).tolist()

