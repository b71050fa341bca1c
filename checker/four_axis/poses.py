"""Intermediate poses between consecutive blocks, interpolated the way the machine moves.

Between two blocks the controller moves linearly in machine X, Y, Z and B (DESIGN.md: a part
point p sits at Ry(B)(p - c) + c). The tool tip therefore follows a curve in the part frame, and
the tool axis turns with B. Poses are spaced so that neither the machine chord nor |dB| between
two checked poses exceeds the configured steps. mm and degrees.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.four_axis.axes import axis_for_b, rotate_about_y


@dataclass(frozen=True)
class Poses:
    """M poses strictly between blocks: the block each follows (`move`, index into the input),
    the fraction of that move (`t` in (0, 1)), the tip and axis in the part frame, and B."""

    move: np.ndarray
    t: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    b: np.ndarray


def intermediate_poses(
    tips: np.ndarray,
    b_deg: np.ndarray,
    center: np.ndarray,
    *,
    max_chord: float,
    max_db: float,
    moves: np.ndarray | None = None,
) -> Poses:
    """Poses between block i and i+1 for every i in `moves` (default: all consecutive pairs).

    tips: (N, 3) tool tips in the part frame, mm; b_deg: (N,) table angles; center: (3,) table
    centre in machine coordinates, mm.
    """
    tips = np.asarray(tips, dtype=float)
    b_deg = np.asarray(b_deg, dtype=float)
    center = np.asarray(center, dtype=float)
    if moves is None:
        moves = np.arange(max(len(tips) - 1, 0))
    moves = np.asarray(moves, dtype=np.int64)
    machine = rotate_about_y(tips, b_deg, center)
    chord = np.linalg.norm(machine[moves + 1] - machine[moves], axis=1)
    turn = np.abs(b_deg[moves + 1] - b_deg[moves])
    steps = np.maximum(np.ceil(chord / max_chord), np.ceil(turn / max_db)).astype(np.int64)
    steps = np.maximum(steps, 1)
    inner = steps - 1  # poses strictly inside each move
    move = np.repeat(moves, inner)
    first = np.repeat(np.cumsum(inner) - inner, inner)
    k = np.arange(move.size) - first + 1
    t = k / np.repeat(steps, inner)
    m = machine[move] + t[:, None] * (machine[move + 1] - machine[move])
    b = b_deg[move] + t * (b_deg[move + 1] - b_deg[move])
    tip = rotate_about_y(m, -b, center)
    return Poses(move, t, tip, axis_for_b(b), b)
