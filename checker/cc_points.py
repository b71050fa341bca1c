"""The one validation of CC points and their normals, for `pathcheck allowable --cc` (rows of a
CSV file, errors naming its line) and the service's `allowable` op (rows of the request's `cc`
field, errors naming `cc.K`): normals made unit without overflow, a zero normal refused, and a
point farther from the part's box than the box's diagonal refused. Part frame, mm."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError


@dataclass(frozen=True)
class Rows:
    """Where CC rows came from, to name row k in an error: a file (`path`, each row's 1-based
    `lines`) or a request field (`field`)."""

    path: str | Path | None = None
    lines: Sequence[int] | None = None
    field: str | None = None

    def error(self, k: int, message: str) -> PathcheckError:
        if self.field is not None:
            return PathcheckError(f"field '{self.field}.{k}': {message}", code="request")
        line = None if self.lines is None else int(self.lines[k])
        return PathcheckError(message, path=self.path, line=line, code="input")


def _shown(row: np.ndarray) -> str:
    return ", ".join(f"{v:.6g}" for v in row)


def unit_normals(normals: np.ndarray, rows: Rows) -> np.ndarray:
    """`normals (N, 3)` scaled to unit length: each row divided by its largest component first,
    so that components up to the largest float (1e308) neither overflow nor warn; a row that
    is not finite or is zero is an error naming it."""
    v = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    finite = np.isfinite(v).all(axis=1)
    scale = np.abs(np.where(finite[:, None], v, 0.0)).max(axis=1, initial=0.0)
    bad = np.flatnonzero(~finite | ~(scale > 0.0))
    if bad.size:
        k = int(bad[0])
        raise rows.error(k, f"expected a finite non-zero normal (nx, ny, nz), found "
                            f"({_shown(v[k])})")
    w = v / scale[:, None]
    return w / np.linalg.norm(w, axis=1)[:, None]


def check_reach(cc: np.ndarray, bbox, rows: Rows) -> None:
    """CC points lie on the part: one farther from the part's box `bbox` ((3,), (3,)) than the
    box's diagonal (at least 1 mm), or not finite, is an error naming its row (the search near
    it would mean nothing)."""
    lo, hi = np.asarray(bbox[0], float), np.asarray(bbox[1], float)
    reach = max(float(np.linalg.norm(hi - lo)), 1.0)
    cc = np.asarray(cc, dtype=np.float64).reshape(-1, 3)
    with np.errstate(over="ignore", invalid="ignore"):
        outside = (np.maximum(lo - cc, 0.0) + np.maximum(cc - hi, 0.0)).max(axis=1, initial=0.0)
    far = np.flatnonzero(~(outside <= reach))
    if far.size:
        k = int(far[0])
        raise rows.error(k, f"CC point ({_shown(cc[k])}) lies {outside[k]:.6g} mm outside the "
                            f"part's box: expected points on the part (within {reach:.6g} mm)")
