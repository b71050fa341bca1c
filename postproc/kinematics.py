"""Part <-> machine kinematics of the horizontal 4-axis machine (DESIGN.md conventions).

A part point ``p`` (part frame, mm) sits at machine position ``Ry(b) (p - c) + c`` where ``c`` is
``table_center`` and ``b = b_direction * B_word`` (degrees at the interface, radians inside). The
spindle is machine +Z, so the tool axis seen in the part frame is ``(-sin b, 0, cos b)``.
All functions take arrays of any length N.
"""

from __future__ import annotations

import numpy as np

from checker.four_axis.axes import axis_for_b, b_for_axis, check_four_axis, rotate_about_y
from postproc.machine import Machine

#: sub-steps used to integrate the tip path relative to the part over one block
PATH_SUBSTEPS = 16


def _rotate_y(v: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` about +Y by ``theta (...)`` radians (right-hand rule)."""
    return rotate_about_y(v, np.degrees(theta), np.zeros(3))


def rotation_rad(b_word: np.ndarray, machine: Machine) -> np.ndarray:
    """Part rotation about +Y in radians for B words in degrees ``(N,)``."""
    return np.radians(machine.kinematics.b_direction * np.asarray(b_word, dtype=float))


def part_to_machine(tip: np.ndarray, b_word: np.ndarray, machine: Machine) -> np.ndarray:
    """Machine X, Y, Z ``(N, 3)`` mm (work frame) of part-frame tips ``(N, 3)`` at B words (deg)."""
    c = np.asarray(machine.kinematics.table_center, dtype=float)
    return _rotate_y(np.asarray(tip, dtype=float) - c, rotation_rad(b_word, machine)) + c


def machine_to_part(
    xyz: np.ndarray, b_word: np.ndarray, machine: Machine
) -> tuple[np.ndarray, np.ndarray]:
    """Part-frame tip ``(N, 3)`` mm and unit tool axis ``(N, 3)`` for machine X, Y, Z ``(N, 3)``
    (work frame, mm) at B words ``(N,)`` degrees."""
    c = np.asarray(machine.kinematics.table_center, dtype=float)
    theta = rotation_rad(b_word, machine)
    tip = _rotate_y(np.asarray(xyz, dtype=float) - c, -theta) + c
    return tip, axis_from_rotation(theta)


def axis_from_rotation(theta: np.ndarray) -> np.ndarray:
    """Part-frame tool axis ``(N, 3)`` for part rotations ``theta (N,)`` radians."""
    return axis_for_b(np.degrees(theta))


def rotation_from_axis(
    axis: np.ndarray,
    *,
    j_tolerance: float = 1e-6,
    lines: np.ndarray | None = None,
    path: str | None = None,
) -> np.ndarray:
    """Part rotation ``b (N,)`` degrees that puts part-frame axes ``(N, 3)`` along the spindle:
    ``b = atan2(-i, k)``. An axis with ``|j| > j_tolerance`` is not a 4-axis-about-Y axis (an
    error naming ``path`` and the line from ``lines``)."""
    axis = np.asarray(axis, dtype=float)
    check_four_axis(axis, lines, path, j_tolerance)
    return b_for_axis(axis)


def tip_path_length(
    xyz0: np.ndarray, xyz1: np.ndarray, b0: np.ndarray, b1: np.ndarray, machine: Machine
) -> np.ndarray:
    """Length (mm) of the tool tip's path relative to the part over blocks whose machine X, Y, Z
    ``(N, 3)`` and B words ``(N,)`` (deg) are interpolated linearly from 0 to 1, as a control does.
    Exact for blocks without B motion; others are integrated over PATH_SUBSTEPS chords."""
    xyz0, xyz1 = np.asarray(xyz0, dtype=float), np.asarray(xyz1, dtype=float)
    length = np.linalg.norm(xyz1 - xyz0, axis=1)
    th0, th1 = rotation_rad(b0, machine), rotation_rad(b1, machine)
    turning = np.flatnonzero(th0 != th1)
    if turning.size:
        c = np.asarray(machine.kinematics.table_center, dtype=float)
        p0, dp = xyz0[turning] - c, (xyz1 - xyz0)[turning]
        a0, da = th0[turning], (th1 - th0)[turning]
        total = np.zeros(turning.size)
        prev = _rotate_y(p0, -a0)
        for k in range(1, PATH_SUBSTEPS + 1):  # a loop over sub-steps, each over all blocks
            t = k / PATH_SUBSTEPS
            tip = _rotate_y(p0 + t * dp, -(a0 + t * da))
            total += np.linalg.norm(tip - prev, axis=1)
            prev = tip
        length[turning] = total
    return length
