"""Where every link of the machine is at a pose, and how fast its points can move along a move
(docs/MATH.md §16). The common frame is the *bed frame*: the machine frame in which the table's
base stands still (at every rotary word 0 it is the work frame). A table link j (table axes
T1 .. Tn, bed -> part) carries its points by A_j = T1 ∘ .. ∘ Tj; the part, the stock and the
fixtures by A_n ∘ setup. The tool side is at machine position X: a head link j (head axes
H1 .. Hm, ram -> spindle, pivots at `point + (0, 0, tool_length)` from the zero-angle tip)
carries a point p of the tip frame to X + H1 ∘ .. ∘ Hj (p); the tool (tip frame: tip at the
origin, axis +Z) rides the last; the spindle frame is the tip frame moved up by the gauge
length G. Each T or H turns right-handed about its direction through its point by its word.

Speeds (per unit of a move's parameter t, joints and X linear in t): a point x rigid in table
link j moves at most Σ_{k<=j} |dθ_k| (|x - c_j| + Σ_{i=k}^{j-1} |c_{i+1} - c_i|), since each
joint k turns it about a line through c_k, |x - c_j| is kept by every joint (c_j rides link
j - 1 and T_j fixes it) and so is |c_{i+1} - c_i|; a point of head link j likewise about the
pivots c'_k, plus the speed of X. Without tool-centre-point control X runs straight (|ΔX|);
with it the program's tip p_w runs straight in the work frame and X = A_n(p_w) - H(0), so
|X'| <= |Δp_w| + Σ_table |dθ_k| (max_ends |p_w - c_n| + Σ_{i>=k} |c_{i+1} - c_i|) + Σ_head
|dθ_k| (max_i |c'_i| + Σ_i |c'_{i+1} - c'_i|): the tip (the tip frame's origin) is within that
of every head pivot (docs/MATH.md §16.3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def rotation_matrices(u: np.ndarray, deg: np.ndarray) -> np.ndarray:
    """(N, 3, 3) right-handed rotations about unit `u (3,)` by `deg (N,)` degrees."""
    th = np.radians(np.asarray(deg, float))
    c, s = np.cos(th), np.sin(th)
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    uu = np.outer(u, u)
    return (c[:, None, None] * np.eye(3) + s[:, None, None] * K
            + (1.0 - c)[:, None, None] * uu)


@dataclass(frozen=True)
class Rigid:
    """N rigid placements: p -> R @ p + t, `R (N, 3, 3)`, `t (N, 3)`."""

    R: np.ndarray
    t: np.ndarray

    @staticmethod
    def identity(n: int) -> Rigid:
        return Rigid(np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), np.zeros((n, 3)))

    def then(self, inner: Rigid) -> Rigid:
        """self ∘ inner."""
        return Rigid(self.R @ inner.R, np.einsum("nij,nj->ni", self.R, inner.t) + self.t)

    def apply(self, p: np.ndarray) -> np.ndarray:
        """(N, 3) the placements of one point `p (3,)` or of `p (N, 3)`."""
        p = np.broadcast_to(np.asarray(p, float), self.t.shape)
        return np.einsum("nij,nj->ni", self.R, p) + self.t

    def shifted(self, d: np.ndarray) -> Rigid:
        """self ∘ (translation by `d`, (3,) or (N, 3))."""
        d = np.broadcast_to(np.asarray(d, float), self.t.shape)
        return Rigid(self.R, self.t + np.einsum("nij,nj->ni", self.R, d))

    def take(self, rows: np.ndarray) -> Rigid:
        return Rigid(self.R[rows], self.t[rows])


def _turn(u: np.ndarray, c: np.ndarray, deg: np.ndarray) -> Rigid:
    R = rotation_matrices(u, deg)
    return Rigid(R, c - np.einsum("nij,j->ni", R, c))


class Links:
    """The links of a chain (`postproc.kinematics.Chain`) at poses: `table(j)` A_j (j = 0: the
    bed), `head(j)` (the tool side's link j, j = 0: the ram), the part, tool and spindle frames;
    `speeds` the speed bounds of the module docstring."""

    def __init__(self, chain) -> None:
        self.chain = chain
        self.c = np.asarray(chain.point, float).reshape(-1, 3)
        self.u = np.asarray(chain.direction, float).reshape(-1, 3)
        self.lift = np.array([0.0, 0.0, float(chain.tool_length)])
        self.setup = Rigid(np.asarray(chain.rot, float)[None], np.asarray(chain.origin,
                                                                          float)[None])

    def place(self, X: np.ndarray, joints: np.ndarray) -> tuple[list[Rigid], list[Rigid]]:
        """(table placements [A_0 = I, A_1 .. A_n], tool-side placements [ram, B_1 .. B_m]) at
        machine positions `X (N, 3)` and words `joints (N, k)`; B_j maps the tip frame."""
        n = len(X)
        table = [Rigid.identity(n)]
        for i in self.chain.table:
            table.append(table[-1].then(_turn(self.u[i], self.c[i], joints[:, i])))
        head = [Rigid(np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), np.asarray(X, float))]
        for i in self.chain.head:
            head.append(head[-1].then(_turn(self.u[i], self.c[i] + self.lift, joints[:, i])))
        return table, head

    def machine_x(self, xyz: np.ndarray, joints: np.ndarray, tcp: bool) -> np.ndarray:
        """(N, 3) machine positions X of program `xyz` (with tcp: work-frame tips)."""
        if not tcp:
            return np.asarray(xyz, float)
        table, _ = self.place(np.zeros_like(xyz), joints)
        return table[-1].apply(xyz) - self.chain.head_offset(joints)

    def table_arms(self, j: int, radius: float) -> np.ndarray:
        """(k,) per joint, the arm of a point within `radius` of table link j's pivot c_j (j >= 1;
        0 for joints that do not carry it)."""
        arms = np.zeros(self.chain.k)
        idx = self.chain.table[:j]
        for pos, k in enumerate(idx):
            arms[k] = radius + sum(np.linalg.norm(self.c[idx[i + 1]] - self.c[idx[i]])
                                   for i in range(pos, j - 1))
        return arms

    def head_arms(self, j: int, radius: float) -> np.ndarray:
        """(k,) the arms of a point within `radius` of head link j's pivot (j >= 1)."""
        arms = np.zeros(self.chain.k)
        idx = self.chain.head[:j]
        piv = self.c + self.lift
        for pos, k in enumerate(idx):
            arms[k] = radius + sum(np.linalg.norm(piv[idx[i + 1]] - piv[idx[i]])
                                   for i in range(pos, j - 1))
        return arms

    def pivot(self, side: str, j: int) -> np.ndarray:
        """The pivot c_j of table or head link j (j >= 1), tip frame for the head."""
        if side == "table":
            return self.c[self.chain.table[j - 1]]
        return self.c[self.chain.head[j - 1]] + self.lift

    def x_speed(self, xyz: np.ndarray, joints: np.ndarray, a: np.ndarray, e: np.ndarray,
                tcp: bool) -> np.ndarray:
        """(M,) the speed bound of X along the moves from poses `a` to `e` (docstring)."""
        if not tcp:
            return np.linalg.norm(xyz[e] - xyz[a], axis=1)
        turn = np.radians(np.abs(joints[e] - joints[a]))
        out = np.linalg.norm(xyz[e] - xyz[a], axis=1)
        table = self.chain.table
        if table:
            cn = self.c[table[-1]]
            far = np.maximum(np.linalg.norm(xyz[a] - cn, axis=1),
                             np.linalg.norm(xyz[e] - cn, axis=1))
            for pos, k in enumerate(table):
                tail = sum(np.linalg.norm(self.c[table[i + 1]] - self.c[table[i]])
                           for i in range(pos, len(table) - 1))
                out = out + turn[:, k] * (far + tail)
        head = self.chain.head
        if head:
            piv = self.c[head] + self.lift
            reach = np.linalg.norm(piv, axis=1).max() + np.linalg.norm(
                np.diff(piv, axis=0), axis=1).sum()
            out = out + turn[:, head].sum(axis=1) * reach
        return out
