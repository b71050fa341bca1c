"""What the machine really does with a CL file: the poses the tool passes through, in order, and
the kind of move that reaches each one. Canned cycles become their moves (at every hole: to the
hole at the height the tool is at, rapid to the clearance plane, feed to depth, rapid back to
the retract plane, as G81/G83 with G98 do); plunges, retracts and rapids are moves like any
other. A move between two operations is not one (the tool changes, or the table turns to a new
setup between them): the first pose of an operation starts afresh. Arcs come sampled into
chords (`ToolPath.motion_arrays(arc_chord_tol)`), each chord a move. Part frame, mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.toolpath import MotionArrays

START, RAPID, FEED = 0, 1, 2  # how a pose is reached: not at all (a start), at rapid, at feed


@dataclass(frozen=True)
class Moves:
    """P poses: `tip (P, 3)`, unit `axis (P, 3)`, `kind (P,)` of the move that reaches each
    (START, RAPID or FEED), `row (P,)` the motion row it comes from (index into the
    MotionArrays), `hole (P,)` True for the poses a canned cycle adds, `retract (P,)` True where
    the move is a cycle's rapid back out of its hole: it retraces the feed to the bottom, so it
    sweeps no volume that feed did not, and what it touches is that feed's gouge, not a crash.
    The moves are the pairs (i - 1, i) with kind[i] != START."""

    tip: np.ndarray
    axis: np.ndarray
    kind: np.ndarray
    row: np.ndarray
    hole: np.ndarray
    retract: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)

    @property
    def ends(self) -> np.ndarray:
        """Indices i of the poses a move reaches (the move runs from i - 1 to i)."""
        return np.flatnonzero(self.kind != START)


def machine_moves(m: MotionArrays) -> Moves:
    """The poses and moves of motion rows `m` (see the module docstring)."""
    n = len(m)
    holes = m.cycle & ~m.rapid
    if m.cycle_geometry is not None:
        holes &= np.isfinite(m.cycle_geometry[:, 0])
    else:
        holes &= False
    kind = np.where(m.rapid, RAPID, FEED)
    first = np.r_[True, m.op[1:] != m.op[:-1]] if n else np.zeros(0, bool)
    kind[first] = START
    # each hole row becomes 4 poses: above the hole at the height the tool arrives at, the
    # clearance plane, the bottom, the retract plane; every other row stays one pose
    count = np.where(holes, 4, 1)
    at = np.cumsum(count) - count  # first output pose of every row
    p = int(count.sum())
    tip = np.empty((p, 3))
    axis = np.repeat(m.axis, count, axis=0)
    row = np.repeat(np.arange(n), count)
    out_kind = np.repeat(kind, count)
    hole = np.repeat(holes, count)
    retracing = np.zeros(p, dtype=bool)
    plain = ~holes
    tip[at[plain]] = m.tip[plain]
    h = np.flatnonzero(holes)
    if h.size:
        depth, clear, retract = m.cycle_geometry[h].T
        a, q = m.axis[h], m.tip[h]
        tip[at[h] + 1] = q + clear[:, None] * a
        tip[at[h] + 2] = q - depth[:, None] * a
        tip[at[h] + 3] = q + retract[:, None] * a
        # above the hole at the height the tool arrives at (the pose before: the retract plane
        # after a hole), measured along this hole's axis; a first pose: the retract plane
        prev = np.where((h > 0)[:, None], tip[np.maximum(at[h] - 1, 0)], q + retract[:, None] * a)
        arrive = np.einsum("ij,ij->i", prev - q, a)
        tip[at[h]] = q + np.maximum(arrive, clear)[:, None] * a
        out_kind[at[h]] = np.where(kind[h] == START, START, RAPID)
        out_kind[at[h] + 1] = RAPID
        out_kind[at[h] + 2] = FEED
        out_kind[at[h] + 3] = RAPID
        retracing[at[h] + 3] = True
    return Moves(tip, axis, out_kind, row, hole, retracing)
