"""Sane ranges for the numbers in a part file, checked once when a part is read, so that no
number from a file can make the numeric code allocate or loop beyond what the part's size asks
for. The `check_*` helpers raise ValueError("field: what"); `check_surface` / `check_mesh`
(every reader's result goes through them) turn that into one `PathcheckError(code="part")`
naming the file, the surface and the field."""

from __future__ import annotations

import math
import numbers
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError
from checker.part import MeshPart, Surface

MAX_COORDINATE = 1e6  # mm: |x|, |y|, |z| of a pole or a vertex (a 2 km part is not a part)
MAX_DEGREE = 25  # OpenCASCADE's Geom_BSplineSurface::MaxDegree(); the evaluator holds 32
MAX_PARAMETER = 1e9  # |u|, |v| of knots and trim points
MAX_WEIGHT_RATIO = 1e8  # largest / smallest weight of a surface
MAX_TRIM_POINTS = 1_000_000  # trim polyline points per surface (after sampling the curves)


def _fail(where: str, what: str) -> ValueError:
    return ValueError(f"{where}: {what}")


def check_degree(value: object, where: str) -> int:
    """`value` as a degree in [1, MAX_DEGREE] (an integral number), else the error."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _fail(where, f"expected an integer degree, found {value!r:.40}")
    integral = isinstance(value, numbers.Integral) or (
        math.isfinite(value) and float(value).is_integer())
    if not (integral and 1 <= value <= MAX_DEGREE):
        raise _fail(where, f"degree {value!r:.40} out of range, expected 1..{MAX_DEGREE}")
    return int(value)


def check_knots(knots: np.ndarray, degree: int, where: str) -> None:
    """Finite, within MAX_PARAMETER, non-decreasing, no knot repeated more than degree + 1
    times, and a domain [knots[p], knots[-p-1]] of positive width."""
    if not np.isfinite(knots).all() or np.abs(knots).max() > MAX_PARAMETER:
        raise _fail(where, f"knots must be finite and within +-{MAX_PARAMETER:g}")
    if np.any(np.diff(knots) < 0):
        raise _fail(where, "knot vector is not non-decreasing")
    _, counts = np.unique(knots, return_counts=True)
    if counts.max() > degree + 1:
        raise _fail(where, f"a knot repeated {counts.max()} times, at most degree + 1 "
                    f"= {degree + 1} allowed")
    if not knots[degree] < knots[len(knots) - degree - 1]:
        raise _fail(where, "knot vector spans an empty domain")


def check_weights(w: np.ndarray, where: str) -> None:
    """Positive, finite weights whose largest / smallest is at most MAX_WEIGHT_RATIO."""
    if not (np.isfinite(w).all() and (w > 0).all()):
        raise _fail(where, "weights must be positive and finite")
    if w.max() > MAX_WEIGHT_RATIO * w.min():
        raise _fail(where, f"weights range from {w.min():.3g} to {w.max():.3g}, more "
                    f"than a factor {MAX_WEIGHT_RATIO:g}")


def check_coordinates(xyz: np.ndarray, where: str) -> None:
    """Finite coordinates within +-MAX_COORDINATE mm."""
    if not np.isfinite(xyz).all():
        raise _fail(where, "non-finite coordinate (nan or inf)")
    if xyz.size and np.abs(xyz).max() > MAX_COORDINATE:
        raise _fail(where, f"coordinate {np.abs(xyz).max():.4g} mm beyond the range "
                    f"+-{MAX_COORDINATE:g} mm")


def check_trim_loops(loops: list[np.ndarray], where: str) -> None:
    """Finite (u, v) within MAX_PARAMETER, at most MAX_TRIM_POINTS points in all."""
    total = sum(len(lp) for lp in loops)
    if total > MAX_TRIM_POINTS:
        raise _fail(where, f"{total} trim points, more than {MAX_TRIM_POINTS}")
    for lp in loops:
        if not np.isfinite(lp).all() or (lp.size and np.abs(lp).max() > MAX_PARAMETER):
            raise _fail(where, f"trim points must be finite and within "
                        f"+-{MAX_PARAMETER:g}")


def check_surface(s: Surface, path: Path | str) -> None:
    """Every number of surface `s` in its sane range (see the module constants), else
    PathcheckError naming the file, the surface and the field."""
    where = f"surface {s.id} ({s.name[:40]})"
    try:
        check_degree(s.degree_u, "degree_u")
        check_degree(s.degree_v, "degree_v")
        check_knots(s.knots_u, s.degree_u, "knotvector_u")
        check_knots(s.knots_v, s.degree_v, "knotvector_v")
        check_coordinates(s.ctrlpts, "control_points")
        if s.weights is not None:
            check_weights(s.weights, "weights")
        if s.trim is not None:
            check_trim_loops(s.trim.loops, "trims")
    except ValueError as err:
        raise PathcheckError(f"{where}: {err}", path=path, code="part") from err


def check_mesh(m: MeshPart, path: Path | str) -> None:
    """Finite mesh vertices within +-MAX_COORDINATE mm, else PathcheckError naming the file."""
    try:
        check_coordinates(m.vertices, "vertices")
    except ValueError as err:
        raise PathcheckError(str(err), path=path, code="part") from err
