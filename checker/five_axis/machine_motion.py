"""Multi-axis moves as the machine makes them: between two poses the control runs its joints
linearly (program X Y Z and the two rotary words; with tool-centre-point control the X Y Z are
the work-frame tip), so the tool's path relative to the part is the machine's forward kinematics
of linearly interpolated joints, not a straight tip with a turning axis. The joints of every
pose come from the machine's inverse kinematics with the same choice of solutions the post
makes (`Kinematics.words_for_axes` over all motion rows of the job, as `checker.postproc.post` calls
it), so the check sees the motion the posted program commands.

The chain is passed in (`postproc.kinematics.Chain` satisfies `Kinematics`); this module does
not import the post-processor. Part frame, mm; rotary words in degrees, radians inside the
bounds.

**How far a tool point travels along a move** (`MachinePath.lengths`; the certificate of
`checker.verify.along_moves` needs a bound L on the distance any point of the tool that can
touch the part, i.e. a point inside the part's box grown by the reach, travels relative to the
part). The tool's motion relative to the part is a translation plus rotations about the joints'
lines, each joint k turning at the constant rate |dθ_k| (radians per unit t), so a point's speed
is at most the translation's speed plus, per joint, |dθ_k| times its distance from that joint's
line (the velocities add; a rotation at rate w about a line moves a point at w times its distance
from it). With p a tool point in the grown box (work frame `w`, corners `c`):

- *Tool-centre-point control*: the tip runs straight (|Δtip| per unit t) and the tool turns at
  an angular rate at most Σ_k |dθ_k| (the sum of the joints' unit rotation vectors times their
  rates), so the speed of p is at most |Δtip| + Σ_k |dθ_k| |p - tip(t)|. Along a straight tip
  |p - tip(t)| is largest at an end: `E = max over c and both end tips of |c - tip|`, and
  **L = |Δtip| + Σ_k |dθ_k| E**.
- *Without it*: the linear axes move X by |ΔX| (machine frame, an isometry of the part frame).
  A table joint k (table chain T1 .. Tn, bed -> part, turning about lines through points c_j)
  moves the part point under p at |dθ_k| times its distance from the line of T_k, which is
  `dist(T_{k+1} .. T_n (w), line_k) <= |w - c_n| + Σ_{j=k}^{n-1} |c_{j+1} - c_j|` (each T_j
  keeps distances to c_j), and for the innermost table exactly `dist(w, line_n)`; both are
  convex in w, so their maxima over the box are at its corners: ρ_k. A head joint k (head chain
  H1 .. Hm, ram -> spindle, pivots c'_j = point + tool length along Z) moves p at |dθ_k| times
  its distance from its line, at most `|p - pivot_1(t)| + Σ_{j<k} |c'_{j+1} - c'_j|`, where
  pivot_1(t) = X(t) + c'_1 runs straight with X; the table keeps the box within `R_T = max_c
  (|c - c_n| + Σ_j |c_{j+1} - c_j|)` of c_1 (no table: p is the box corner itself), so
  `|p - pivot_1(t)| <= P = R_T + max over the ends of |c_1 - pivot_1|` (no table: `max over c
  and the ends of |c - pivot_1|`). **L = |ΔX| + Σ_table |dθ_k| ρ_k + Σ_head |dθ_k| (P +
  Σ_{j<k} |c'_{j+1} - c'_j|)**.

L bounds the speed uniformly in t, so a stretch [t0, t1] of the move travels at most
(t1 - t0) L, which is what `along_moves` assumes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class Kinematics(Protocol):
    """What the check needs of a machine's chain (`postproc.kinematics.Chain`): k rotary axes,
    `table` / `head` their indices (bed -> part, ram -> spindle), `point (k,3)` and unit
    `direction (k,3)` of each (work frame; head points from the zero-angle pivot),
    `tool_length` (mm), and the kinematics."""

    k: int
    table: list[int]
    head: list[int]
    point: np.ndarray
    direction: np.ndarray
    tool_length: float

    def forward(self, xyz, joints, tcp=False) -> tuple[np.ndarray, np.ndarray]: ...

    def inverse_position(self, tip, joints, tcp=False) -> np.ndarray: ...

    def to_work(self, p: np.ndarray) -> np.ndarray: ...

    def words_for_axes(self, axis, *, start=None, lines=None, path=None,
                       tolerance: float = 1e-3) -> tuple: ...


@dataclass(frozen=True)
class MachineMotion:
    """A machine that moves multi-axis operations `ops` (operation indices): its `chain`,
    whether it runs with tool-centre-point control (`tcp`), and `tolerance` (degrees) within
    which a tool axis must be one the chain can make (the post's)."""

    chain: Kinematics
    tcp: bool
    tolerance: float
    ops: frozenset[int]

    def joints(self, axis: np.ndarray, lines: np.ndarray, path: str | None) -> np.ndarray:
        """Rotary words `(N, k)` degrees, continuous, for part-frame tool axes `(N, 3)` of
        consecutive motion rows, chosen as the post chooses them."""
        words, _, _ = self.chain.words_for_axes(axis, lines=lines, path=path,
                                                tolerance=self.tolerance)
        return np.asarray(words, float)

    def path(self, tip: np.ndarray, joints: np.ndarray) -> MachinePath:
        """The poses `tip (P, 3)` (part frame) at rotary words `joints (P, k)` as program
        positions."""
        xyz = self.chain.inverse_position(tip, joints, self.tcp)
        return MachinePath(self, np.asarray(xyz, float), np.asarray(joints, float),
                           np.asarray(tip, float))


@dataclass(frozen=True)
class MachinePath:
    """Per pose: program `xyz (P, 3)` (machine X Y Z, or the work-frame tip with tcp), rotary
    words `joints (P, k)` degrees and the part-frame `tip (P, 3)`. A move runs from pose
    i - 1 to pose i."""

    motion: MachineMotion
    xyz: np.ndarray
    joints: np.ndarray
    tip: np.ndarray

    def pose_at(self, end: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Part-frame tips and unit axes `(M, 3)` at fraction `t (M,)` of the moves ending at
        poses `end (M,)`: joints linear, then forward kinematics."""
        a = end - 1
        tt = np.asarray(t, float)[:, None]
        xyz = self.xyz[a] + tt * (self.xyz[end] - self.xyz[a])
        joints = self.joints[a] + tt * (self.joints[end] - self.joints[a])
        tip, axis = self.motion.chain.forward(xyz, joints, self.motion.tcp)
        return tip, axis / np.linalg.norm(axis, axis=1, keepdims=True)

    def lengths(self, end: np.ndarray, box: np.ndarray) -> np.ndarray:
        """(M,) mm: how far any tool point inside the part's box `box (2, 3)` (part frame,
        already grown by the reach) travels relative to the part along each move ending at
        `end`, at most (the module docstring's L)."""
        chain, a = self.motion.chain, end - 1
        corners = np.array([[box[i, 0], box[j, 1], box[k, 2]] for i in (0, 1) for j in (0, 1)
                            for k in (0, 1)])
        turn = np.radians(np.abs(self.joints[end] - self.joints[a]))  # (M, k)
        if self.motion.tcp:
            far = np.maximum(_farthest(corners, self.tip[a]), _farthest(corners, self.tip[end]))
            return (np.linalg.norm(self.tip[end] - self.tip[a], axis=1)
                    + turn.sum(axis=1) * far)
        work = chain.to_work(corners)
        out = np.linalg.norm(self.xyz[end] - self.xyz[a], axis=1)
        table, head = list(chain.table), list(chain.head)
        c = np.asarray(chain.point, float)
        if table:
            cn = c[table[-1]]
            steps = np.r_[[np.linalg.norm(c[table[j + 1]] - c[table[j]])
                           for j in range(len(table) - 1)], 0.0]
            tail = np.cumsum(steps[::-1])[::-1]  # Σ_{j >= i} |c_{j+1} - c_j|
            from_cn = np.linalg.norm(work - cn, axis=1).max()
            for i, k in enumerate(table):
                if i == len(table) - 1:
                    d = chain.direction[k]
                    rel = work - cn
                    rho = np.linalg.norm(rel - np.outer(rel @ d, d), axis=1).max()
                else:
                    rho = from_cn + tail[i]
                out = out + turn[:, k] * rho
        if head:
            lift = np.array([0.0, 0.0, float(chain.tool_length)])
            pivots = c[head] + lift
            pivot_a, pivot_e = self.xyz[a] + pivots[0], self.xyz[end] + pivots[0]
            if table:
                c1 = c[table[0]]
                reach_t = from_cn + tail[0]
                p = reach_t + np.maximum(np.linalg.norm(pivot_a - c1, axis=1),
                                         np.linalg.norm(pivot_e - c1, axis=1))
            else:
                p = np.maximum(_farthest(work, pivot_a), _farthest(work, pivot_e))
            offset = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pivots, axis=0), axis=1))]
            for i, k in enumerate(head):
                out = out + turn[:, k] * (p + offset[i])
        return out


def _farthest(points: np.ndarray, at: np.ndarray) -> np.ndarray:
    """(M,) the largest distance from each of `at (M, 3)` to `points (K, 3)`."""
    return np.linalg.norm(points[None] - at[:, None], axis=2).max(axis=1)


def machine_path(motion: MachineMotion, rows_axis: np.ndarray, lines: np.ndarray,
                 path: str | None, pose_row: np.ndarray, pose_tip: np.ndarray) -> MachinePath:
    """The program positions of the poses (`pose_tip (P, 3)`, from motion rows `pose_row
    (P,)`): the words chosen over all motion rows' axes `rows_axis (N, 3)` (as the post
    chooses them), each pose taking its row's words."""
    joints = motion.joints(rows_axis, lines, path)
    return motion.path(pose_tip, joints[pose_row])
