"""The program's motion as the stock simulation sweeps it: per operation, its moves as items of
the removal kernel (`checker.stock.removal`), each the tool translating at one axis from a tip to
a tip (docs/MATH.md §14). A move whose axis does not turn (3-axis, indexed, a 4-axis move at one
B) is one item, swept exactly; a move whose axis turns (the table turning, a 5-axis move with its
joints linear) becomes its poses, spaced so that no tool point inside the stock's box travels more
than `step` between two of them (`checker.verify.move_lengths`, `MachinePath.lengths`). The
first pose of an operation is an item of its own. Part frame, mm."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.moves import START, Moves
from checker.verify import move_lengths, pose_at

_SAME_AXIS = 1e-12  # 1 - cos of the turn below which a move keeps its axis


class Items(NamedTuple):
    """S kernel items: tips `a (S, 3)` to `b (S, 3)` at unit `axis (S, 3)`, of pose `move (S,)`
    (the index of the pose the move reaches: the stock's statistics are per pose)."""

    a: np.ndarray
    b: np.ndarray
    axis: np.ndarray
    move: np.ndarray


def sweep_items(moves: Moves, poses: np.ndarray, box: np.ndarray, step: float,
                b: np.ndarray | None = None, center: np.ndarray | None = None,
                path=None) -> Items:
    """The items of poses `poses` (one operation's, ascending): each START pose alone, each
    move (i - 1, i) as one translation or as its poses `step` mm apart. With table angles `b`
    (per pose, degrees) the machine moves linearly in X Y Z B about Y through `center`; with
    `path` (a `checker.five_axis.machine_motion.MachinePath`) its joints run linearly."""
    center = np.zeros(3) if center is None else np.asarray(center, float)
    poses = np.asarray(poses, dtype=np.int64)
    starts = poses[moves.kind[poses] == START]
    ends = poses[moves.kind[poses] != START]
    turning = 1.0 - np.einsum("ij,ij->i", moves.axis[ends - 1], moves.axis[ends]) > _SAME_AXIS
    if b is not None:
        turning |= b[ends - 1] != b[ends]
    if path is not None:
        turning |= np.any(path.joints[ends - 1] != path.joints[ends], axis=1)
    flat, bent = ends[~turning], ends[turning]
    parts = [Items(moves.tip[starts], moves.tip[starts], moves.axis[starts], starts),
             Items(moves.tip[flat - 1], moves.tip[flat], moves.axis[flat], flat)]
    if bent.size:
        length = (move_lengths(moves, bent, box, b, center) if path is None
                  else path.lengths(bent, box))
        count = np.maximum(np.ceil(length / step).astype(np.int64), 1)
        end = np.repeat(bent, count)
        first = np.cumsum(count) - count
        t = (np.arange(int(count.sum())) - np.repeat(first, count) + 1) / np.repeat(count, count)
        tip, axis = pose_at(moves, end, t, b, center) if path is None else path.pose_at(end, t)
        parts.append(Items(tip, tip, axis, end))
    cat = Items(*(np.concatenate([p[f] for p in parts]) for f in range(4)))
    order = np.argsort(cat.move, kind="stable")  # program order; a move's poses in order of t
    return Items(*(f[order] for f in cat))
