"""The tool motion: a C2 interpolation of the CL poses (tip and axis as cubic splines of a path
parameter t, the axis normalised) with first derivatives. Part frame, mm; t in mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline


def path_parameter(tips: np.ndarray, axes: np.ndarray, length: float) -> np.ndarray:
    """(N,) t at the poses: the cumulated mean travel of the tip and of the axis point
    `length` mm above it (mm), so that a pure rotation still advances t."""
    top = tips + length * axes
    step = 0.5 * (np.linalg.norm(np.diff(tips, axis=0), axis=1)
                  + np.linalg.norm(np.diff(top, axis=0), axis=1))
    return np.concatenate([[0.0], np.cumsum(step)])


@dataclass(frozen=True)
class MotionState:
    """The motion at parameters t (T,): tip, d tip/dt, unit axis, d axis/dt, all (T, 3)."""

    tip: np.ndarray
    tip_dt: np.ndarray
    axis: np.ndarray
    axis_dt: np.ndarray


class ToolMotion:
    """Cubic splines (not-a-knot) through the poses' tips and axes over `t` (N,) increasing;
    the axis is the spline normalised, so it is unit everywhere and exact at the poses."""

    def __init__(self, t: np.ndarray, tips: np.ndarray, axes: np.ndarray) -> None:
        self.t = np.asarray(t, dtype=float)
        self._tip = CubicSpline(self.t, tips, axis=0)
        self._axis = CubicSpline(self.t, axes, axis=0)

    @classmethod
    def through(cls, tips: np.ndarray, axes: np.ndarray, length: float) -> ToolMotion:
        """The motion through poses (N, 3) tips and unit axes, parametrised by
        `path_parameter` with the axis point `length` mm above the tip."""
        return cls(path_parameter(tips, axes, length), tips, axes)

    def at(self, t: np.ndarray) -> MotionState:
        """The state at parameters t (T,), within [t0, tN]."""
        t = np.asarray(t, dtype=float)
        A, dA = self._axis(t), self._axis(t, 1)
        norm = np.linalg.norm(A, axis=1, keepdims=True)
        a = A / norm
        da = (dA - a * np.einsum("ij,ij->i", a, dA)[:, None]) / norm
        return MotionState(self._tip(t), self._tip(t, 1), a, da)
