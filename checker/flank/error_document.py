"""The flank document (pydantic): per pose and per move the largest overcut and undercut, the
worst moves, the error map over the design surface's (u, v), before and (with the
optimisation) after. Errors in mm, > 0 overcut (docs/MATH.md §12.3)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict
from scipy.interpolate import griddata

from checker.flank.error import ErrorField, grid_uv
from checker.part import Surface

SIGN = "error > 0: overcut (the envelope inside the material); < 0: undercut (material left)"


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class PoseError(_Model):
    """One CL pose: its index in the pass, file line, largest overcut and undercut (mm, both
    >= 0; None where its grazing curve does not meet the surface)."""

    index: int
    line: int
    max_overcut: float | None
    max_undercut: float | None


class MoveError(_Model):
    """One move (pose `index` -> `index + 1`), sampled along its interpolation."""

    index: int
    from_line: int
    to_line: int
    max_overcut: float | None
    max_undercut: float | None


class ErrorSummary(_Model):
    """Over the whole pass: largest overcut and undercut (mm, >= 0), root mean square error
    (mm) and the number of envelope points that met the surface."""

    max_overcut: float
    max_undercut: float
    rms: float
    points: int


class ErrorMap(_Model):
    """The error (mm) on an even (u, v) grid of the design surface: error[i][j] at (u[i],
    v[j]), interpolated linearly between the envelope's hits; None outside them."""

    u: list[float]
    v: list[float]
    error: list[list[float | None]]


class FlankResult(_Model):
    """The error of one path."""

    summary: ErrorSummary
    poses: list[PoseError]
    worst_moves: list[MoveError]
    map: ErrorMap


class Optimisation(_Model):
    """What the optimiser did and where the improved path went."""

    evaluations: int
    message: str
    written: str | None


class FlankDocument(_Model):
    """`pathcheck flank` output."""

    kind: Literal["flank"] = "flank"
    version: int = 1
    job: str
    part: str
    surface: int
    cutter: str
    heights: list[float]
    tolerance: float
    sign: str = SIGN
    status: Literal["ok", "findings"]
    before: FlankResult
    after: FlankResult | None = None
    optimisation: Optimisation | None = None


def _extreme(values: np.ndarray, groups: np.ndarray, count: int, sign: float) -> list:
    """Per group the largest `sign * value` clipped at 0 (None for a group with no value)."""
    out = np.full(count, -np.inf)
    ok = np.isfinite(values)
    np.maximum.at(out, groups[ok], sign * values[ok])
    return [None if not np.isfinite(x) else max(float(x), 0.0) for x in out]


def _none(x: float) -> float | None:
    return None if not np.isfinite(x) else float(x)


def error_map(field: ErrorField, surface: Surface, n: int) -> ErrorMap:
    """The error on an n x n grid of the surface's domain, linear between the hits."""
    U, V = grid_uv(surface, n)
    ok = np.isfinite(field.error)
    grid = np.full(U.shape, np.nan)
    if ok.sum() >= 3:
        uv = field.uv[ok]
        if np.linalg.matrix_rank(uv - uv.mean(axis=0), tol=1e-12) == 2:
            grid = griddata(uv, field.error[ok], (U, V), method="linear")
    return ErrorMap(u=U[:, 0].tolist(), v=V[0].tolist(),
                    error=[[_none(x) for x in row] for row in grid])


def flank_result(field: ErrorField, surface: Surface, lines: np.ndarray, worst: int = 10,
                 grid: int = 41) -> FlankResult:
    """The result of a field whose poses are at file `lines` (N,): per pose, the `worst`
    moves by their larger of overcut and undercut, the summary and the map."""
    n = len(lines)
    tz = field.error.shape
    e = field.error.ravel()
    pose = np.broadcast_to(field.pose[:, None], tz).ravel()
    seg = np.broadcast_to(field.segment[:, None], tz).ravel()
    at_pose = pose >= 0
    p_over = _extreme(e[at_pose], pose[at_pose], n, 1.0)
    p_under = _extreme(e[at_pose], pose[at_pose], n, -1.0)
    m_over = _extreme(e, seg, n - 1, 1.0)
    m_under = _extreme(e, seg, n - 1, -1.0)
    poses = [PoseError(index=i, line=int(lines[i]), max_overcut=p_over[i],
                       max_undercut=p_under[i]) for i in range(n)]
    moves = [MoveError(index=i, from_line=int(lines[i]), to_line=int(lines[i + 1]),
                       max_overcut=m_over[i], max_undercut=m_under[i]) for i in range(n - 1)]
    moves.sort(key=lambda m: -max(m.max_overcut or 0.0, m.max_undercut or 0.0))
    ok = e[np.isfinite(e)]
    summary = ErrorSummary(
        max_overcut=max(float(ok.max(initial=0.0)), 0.0),
        max_undercut=max(float(-ok.min(initial=0.0)), 0.0),
        rms=float(np.sqrt(np.mean(ok**2))) if ok.size else 0.0, points=int(ok.size))
    return FlankResult(summary=summary, poses=poses, worst_moves=moves[:worst],
                       map=error_map(field, surface, grid))
