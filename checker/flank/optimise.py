"""The optimisation of Gong and Wang (2009, §2.2-2.3; docs/MATH.md §12.4): the tool-axis trajectory
surface, given by the axis' lower and upper points B_i, T_i at each pose, is moved by least squares
to bring the envelope onto the design surface: residuals the envelope's errors along its normal at
the heights and path samples where the first envelope meets the surface, plus a smoothness term
(second differences of B and T along the path) and a small pull to the start (the axis' slide along
itself and its spin change nothing). Part frame, mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from checker.cutter import Cutter
from checker.flank.error import ErrorField, envelope_error
from checker.flank.spline_motion import ToolMotion
from checker.part import Surface

REACH = 2  # a pose's points move the spline this many moves away, as far as the Jacobian sees


@dataclass(frozen=True)
class Optimised:
    """The improved poses `tips`, unit `axes` (N, 3), the error fields before and after, the
    optimiser's evaluations and its message."""

    tips: np.ndarray
    axes: np.ndarray
    before: ErrorField
    after: ErrorField
    evaluations: int
    message: str


def _poses(x: np.ndarray, n: int, z_lo: float, z_hi: float) -> tuple[np.ndarray, np.ndarray]:
    B, T = x[: 3 * n].reshape(n, 3), x[3 * n:].reshape(n, 3)
    a = (T - B) / np.linalg.norm(T - B, axis=1, keepdims=True)
    return B - z_lo * a, a


def _sparsity(rows_segment: np.ndarray, n: int, n_smooth: int) -> lil_matrix:
    """Which unknowns (B then T, 3 each per pose) each residual row depends on, as far as the
    Jacobian is estimated: the poses within REACH moves of the row's move."""
    m = len(rows_segment) + n_smooth + 6 * n
    S = lil_matrix((m, 6 * n), dtype=np.int8)
    for r, k in enumerate(rows_segment):
        for i in range(max(0, k - REACH), min(n, k + REACH + 2)):
            S[r, 3 * i:3 * i + 3] = 1
            S[r, 3 * (n + i):3 * (n + i) + 3] = 1
    r0 = len(rows_segment)
    for i in range(1, n - 1):  # second differences of B and T at pose i, 3 rows each
        for half in (0, n):
            for j in range(3):
                row = r0 + 6 * (i - 1) + (3 if half else 0) + j
                for q in (i - 1, i, i + 1):
                    S[row, 3 * (half + q) + j] = 1
    for c in range(6 * n):
        S[r0 + n_smooth + c, c] = 1
    return S


def optimise_axis(cutter: Cutter, surface: Surface, tips: np.ndarray, axes: np.ndarray,
                  z: np.ndarray, per_move: int = 4, smooth: float = 0.05, pull: float = 1e-3,
                  max_evaluations: int = 60) -> Optimised:
    """Least squares (scipy `least_squares`, trust region, finite differences on the banded
    sparsity) over B_i = tip_i + z_lo a_i, T_i = tip_i + z_hi a_i (z_lo, z_hi the ends of the
    heights z (Z,) mm), minimising mean(e^2) + smooth^2 mean(|d2 B|^2 + |d2 T|^2)
    + pull^2 mean(|x - x0|^2), e the envelope's errors (mm) where the first envelope meets the
    surface. Returns the improved poses and both error fields."""
    n = len(tips)
    z = np.asarray(z, dtype=float)
    z_lo, z_hi = float(z.min()), float(z.max())
    length = z_hi
    before = envelope_error(cutter, ToolMotion.through(tips, axes, length), surface, z, per_move)
    mask = np.isfinite(before.error)
    if n < 3 or not mask.any():
        return Optimised(tips, axes, before, before, 0, "nothing to optimise")
    x0 = np.concatenate([(tips + z_lo * axes).ravel(), (tips + z_hi * axes).ravel()])
    w_err = 1.0 / np.sqrt(mask.sum())
    w_smooth = smooth / np.sqrt(6 * (n - 2))
    w_pull = pull / np.sqrt(6 * n)

    def residuals(x: np.ndarray) -> np.ndarray:
        tp, ax = _poses(x, n, z_lo, z_hi)
        f = envelope_error(cutter, ToolMotion.through(tp, ax, length), surface, z, per_move,
                           side=before.side, uv=before.uv)
        e = np.nan_to_num(f.raw[mask], nan=0.0)
        B, T = x[: 3 * n].reshape(n, 3), x[3 * n:].reshape(n, 3)
        d2 = np.concatenate([(B[:-2] - 2 * B[1:-1] + B[2:]), (T[:-2] - 2 * T[1:-1] + T[2:])],
                            axis=1).ravel()
        return np.concatenate([w_err * e, w_smooth * d2, w_pull * (x - x0)])

    rows_segment = np.broadcast_to(before.segment[:, None], mask.shape)[mask]
    sol = least_squares(residuals, x0, jac_sparsity=_sparsity(rows_segment, n, 6 * (n - 2)),
                        method="trf", x_scale=1.0, max_nfev=max_evaluations, xtol=1e-10,
                        ftol=1e-10)
    tp, ax = _poses(sol.x, n, z_lo, z_hi)
    after = envelope_error(cutter, ToolMotion.through(tp, ax, length), surface, z, per_move)
    return Optimised(tp, ax, before, after, int(sol.nfev), str(sol.message))
