"""Forward and inverse kinematics of a machine, derived from its kinematic chain
(`checker.postproc.machine`), vectorised over all moves.

Frames: *part* (CL coordinates), *work* (the table frame at every rotary word 0: work =
``setup.rotation @ part + setup.origin``) and *machine* (the frame of the linear axes). Table
axes ``T1 .. Tn`` (bed -> part) carry a work point ``w`` to the machine position
``T1(T2(... Tn(w)))``; head axes ``H1 .. Hm`` (ram -> spindle) carry the tool: the tip sits at
``xyz + H1(H2(... Hm(0)))`` (pivots measured from the zero-angle tip, i.e. the gauge point minus
the tool length) and the tool axis is ``H1 .. Hm`` applied to +Z. Each ``Tk``/``Hk`` turns right-
handed about its ``direction`` through its ``point`` by its word.

Without tool-centre-point control the program carries machine ``xyz``; with it, the work-frame
tip. Inverse: the tool axis fixes the rotary words (Paden-Kahan subproblems 1 and 2 on the chain's
rotations: for two rotary axes two solutions, the *sheets* +/-), then ``xyz`` follows.
Angles in degrees at this module's boundary, lengths in mm. All arrays have N rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from checker.b_axis import axis_for_b, b_for_axis, check_four_axis
from checker.errors import PathcheckError
from checker.postproc.machine import Machine

#: sub-steps used to integrate the tip path relative to the part over one block
PATH_SUBSTEPS = 16
#: tool axes within this angle (deg) of the first rotation's axis are at the pole (singular)
POLE_DEG = 2.0
_Z = np.array([0.0, 0.0, 1.0])


def rotate(v: np.ndarray, u: np.ndarray, deg: np.ndarray) -> np.ndarray:
    """Vectors ``v (N,3)`` turned right-handed about unit ``u (3,)`` by ``deg (N,)`` degrees
    (Rodrigues)."""
    th = np.radians(np.asarray(deg, dtype=float))[..., None]
    v = np.asarray(v, dtype=float)
    c, s = np.cos(th), np.sin(th)
    return v * c + np.cross(u, v) * s + u * (v @ u)[..., None] * (1.0 - c)


def _subproblem1(p: np.ndarray, q: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angle (deg) turning ``p (N,3)`` into ``q (N,3)`` about unit ``w``, and how far ``p`` is
    from the axis (|p_perp|, 0 at the singularity)."""
    pp = p - np.outer(p @ w, w)
    qp = q - np.outer(q @ w, w)
    ang = np.degrees(np.arctan2(np.cross(pp, qp) @ w, (pp * qp).sum(axis=1)))
    return ang, np.linalg.norm(pp, axis=1)


@dataclass(frozen=True)
class Solutions:
    """Inverse orientation of N tool axes: ``joints (N, 2, k)`` words (deg) of the two sheets
    (equal for k < 2), ``reach (N,)`` the angle (deg) between the asked axis and the nearest one
    the chain can make (0 when reachable), ``pole (N,)`` the angle (deg) between the tool axis and
    the free rotation's axis (small: singular, that word is free)."""

    joints: np.ndarray
    reach: np.ndarray
    pole: np.ndarray


@dataclass(frozen=True)
class Choice:
    """The words the post chose: ``joints (N, k)`` continuous (deg), ``sheet (N,)`` 0/1,
    ``switches`` rows where the sheet changes (for continuity at a pole passage or to stay
    within limits), ``singular`` rows at the pole, ``notes`` one line per event (with the row)."""

    joints: np.ndarray
    sheet: np.ndarray
    switches: np.ndarray
    singular: np.ndarray
    notes: list[tuple[int, str]] = field(default_factory=list)


class Chain:
    """A machine's kinematic chain as arrays (see the module docstring)."""

    def __init__(self, machine: Machine):
        axes = machine.rotary_axes
        self.machine = machine
        self.names = tuple(a.name for a in axes)
        self.k = len(axes)
        self.direction = np.array([a.direction for a in axes], dtype=float).reshape(-1, 3)
        self.point = np.array([a.point for a in axes], dtype=float).reshape(-1, 3)
        self.table = [i for i, a in enumerate(axes) if a.on == "table"]
        self.head = [i for i, a in enumerate(axes) if a.on == "head"]
        self.tool_length = machine.head.tool_length
        self.rot = np.asarray(machine.setup.rotation, dtype=float)
        self.origin = np.asarray(machine.setup.origin, dtype=float)
        self.limits = np.array([a.limits for a in axes], dtype=float).reshape(-1, 2)
        # rotations applied to the work-frame tool axis to reach +Z: Tn .. T1, H1^-1 .. Hm^-1
        self.ops = [(i, 1.0) for i in reversed(self.table)] + [(i, -1.0) for i in self.head]

    # -- forward ----------------------------------------------------------------------------
    def _table(self, pts: np.ndarray, joints: np.ndarray, inverse: bool, vectors=False):
        order = self.table if inverse else list(reversed(self.table))
        sign = -1.0 if inverse else 1.0
        out = np.asarray(pts, dtype=float)
        for i in order:
            c = 0.0 if vectors else self.point[i]
            out = rotate(out - c, self.direction[i], sign * joints[:, i]) + c
        return out

    def head_offset(self, joints: np.ndarray) -> np.ndarray:
        """Tip minus machine xyz ``(N,3)``: the head's rotations carry the zero-angle tip."""
        n = len(joints)
        tip = np.zeros((n, 3))
        lift = np.array([0.0, 0.0, self.tool_length])
        for i in reversed(self.head):
            c = self.point[i] + lift
            tip = rotate(tip - c, self.direction[i], joints[:, i]) + c
        return tip

    def head_axis(self, joints: np.ndarray) -> np.ndarray:
        """Tool axis in the machine frame ``(N,3)``."""
        d = np.tile(_Z, (len(joints), 1))
        for i in reversed(self.head):
            d = rotate(d, self.direction[i], joints[:, i])
        return d

    def to_part(self, w: np.ndarray) -> np.ndarray:
        return (np.asarray(w, float) - self.origin) @ self.rot

    def to_work(self, p: np.ndarray) -> np.ndarray:
        return np.asarray(p, float) @ self.rot.T + self.origin

    def forward(self, xyz, joints, tcp=False) -> tuple[np.ndarray, np.ndarray]:
        """Part-frame tip ``(N,3)`` and unit tool axis ``(N,3)`` for program ``xyz (N,3)`` and
        rotary words ``joints (N,k)``; ``tcp (N,)`` or scalar: the xyz are work-frame tips."""
        xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
        joints = np.asarray(joints, dtype=float).reshape(len(xyz), self.k)
        tcp = np.broadcast_to(np.asarray(tcp, dtype=bool), (len(xyz),))
        axis_w = self._table(self.head_axis(joints), joints, inverse=True, vectors=True)
        tip_w = self._table(xyz + self.head_offset(joints), joints, inverse=True)
        tip_w = np.where(tcp[:, None], xyz, tip_w)
        return self.to_part(tip_w), axis_w @ self.rot

    def inverse_position(self, tip, joints, tcp=False) -> np.ndarray:
        """Program ``xyz (N,3)`` putting the part-frame ``tip (N,3)`` under the tool at
        ``joints (N,k)`` (tcp: the work-frame tip itself)."""
        tip_w = self.to_work(np.asarray(tip, dtype=float).reshape(-1, 3))
        joints = np.asarray(joints, dtype=float).reshape(len(tip_w), self.k)
        if tcp:
            return tip_w
        return self._table(tip_w, joints, inverse=False) - self.head_offset(joints)

    # -- inverse orientation ----------------------------------------------------------------
    def solve(self, axis) -> Solutions:
        """Both solutions of the rotary words for part-frame tool axes ``(N,3)``."""
        a = np.asarray(axis, dtype=float).reshape(-1, 3)
        a = a / np.linalg.norm(a, axis=1, keepdims=True)
        a = a @ self.rot.T  # work frame
        n = len(a)
        z = np.tile(_Z, (n, 1))
        joints = np.zeros((n, 2, self.k))
        pole = np.full(n, 90.0)
        if self.k == 0 or not self.ops:
            reach = np.degrees(np.arccos(np.clip(a[:, 2], -1.0, 1.0)))
            return Solutions(joints, reach, pole)
        if len(self.ops) == 1:
            (i, sign), = self.ops
            w = self.direction[i]
            ang, _ = _subproblem1(a, z, w)
            reach = np.degrees(np.abs(np.arcsin(np.clip(a @ w, -1, 1)) - np.arcsin(w[2])))
            joints[:, :, i] = (sign * ang)[:, None]
            return Solutions(joints, reach, pole)
        if len(self.ops) > 2:
            raise PathcheckError(
                f"machine '{self.machine.name}': {len(self.ops)} rotary axes, expected at most "
                "2 for solving tool axes", code="kinematics")
        (i2, s2), (i1, s1) = self.ops  # i2 is applied first (PK: w2), then i1 (PK: w1)
        w1, w2 = self.direction[i1], self.direction[i2]
        w12 = float(w1 @ w2)
        cross = np.cross(w1, w2)
        if np.linalg.norm(cross) < 1e-9:
            raise PathcheckError(
                f"machine '{self.machine.name}': rotary axes {self.names[i1]} and "
                f"{self.names[i2]} are parallel: expected two independent directions",
                code="kinematics")
        den = w12**2 - 1.0
        alpha = (w12 * (a @ w2) - z @ w1) / den
        beta = (w12 * (z @ w1) - a @ w2) / den
        g2 = (1.0 - alpha**2 - beta**2 - 2 * alpha * beta * w12) / float(cross @ cross)
        gamma = np.sqrt(np.maximum(g2, 0.0))
        base = np.outer(alpha, w1) + np.outer(beta, w2)
        # an unreachable axis (gamma^2 < 0) gets the words of the nearest one (gamma = 0)
        for s, sheet in ((1.0, 0), (-1.0, 1)):
            c = base + s * np.outer(gamma, cross)
            c = c / np.maximum(np.linalg.norm(c, axis=1, keepdims=True), 1e-12)
            t2, _ = _subproblem1(a, c, w2)
            t1, _ = _subproblem1(c, z, w1)
            joints[:, sheet, i2] = s2 * t2
            joints[:, sheet, i1] = s1 * t1
        # how far a is from the set it must lie on: compare a with the axis that the words give
        back = rotate(rotate(a, w2, joints[:, 0, i2] * s2), w1, joints[:, 0, i1] * s1)
        reach = np.where(g2 < 0, np.degrees(np.arccos(np.clip((back * z).sum(1), -1, 1))), 0.0)
        pole = np.degrees(np.arccos(np.clip(np.abs(a @ w2), 0.0, 1.0)))
        return Solutions(joints, reach, pole)

    # -- choice -----------------------------------------------------------------------------
    def choose(self, sol: Solutions, *, start: np.ndarray | None = None,
               lines: np.ndarray | None = None) -> Choice:
        """Words along a path: per row the sheet, kept for continuity (a switch where it
        moves the axes less: passing the pole) and changed where the chosen sheet leaves a
        rotary limit; then each axis made continuous (unwrapped) and shifted by whole turns
        into its limits. ``start (k,)``: the words before the path (default: the first row's
        nearest 0). ``lines`` name the rows in the notes."""
        j = sol.joints
        n, k = len(j), self.k
        if k == 0:
            return Choice(np.zeros((n, 0)), np.zeros(n, int), np.zeros(0, int),
                          np.zeros(0, int))
        lines = np.arange(1, n + 1) if lines is None else np.asarray(lines)

        def wrapped(d):
            return (d + 180.0) % 360.0 - 180.0

        span = self.limits[:, 1] - self.limits[:, 0]
        narrow = span < 360.0 - 1e-9

        def inside(v):  # (N, k) -> (N,) every narrow axis has a turn that fits its limits
            lo, hi = self.limits[:, 0], self.limits[:, 1]
            m = np.ceil((lo - v) / 360.0 - 1e-9)
            return np.all(~narrow | (v + 360.0 * m <= hi + 1e-9), axis=1)

        two = len(self.ops) == 2
        sheet = np.zeros(n, int)
        switches: list[int] = []
        notes: list[tuple[int, str]] = []
        if two and n:
            # compare each row with the previous row off the pole (at the pole both solutions
            # meet, so crossing it is where the other solution continues the path)
            at_pole = sol.pole < 1e-6
            idx = np.where(at_pole, -1, np.arange(n))
            prev = np.concatenate([[-1], np.maximum.accumulate(idx)[:-1]])
            has = (prev >= 0) & ~at_pole
            pj = j[np.maximum(prev, 0)]
            d = np.abs(wrapped(j[:, :, None, :] - pj[:, None, :, :])).sum(-1)  # (n, to, from)
            stay = 0.5 * (d[:, 0, 0] + d[:, 1, 1])
            swap = 0.5 * (d[:, 1, 0] + d[:, 0, 1])
            flip = has & (swap < stay - 1e-9)
            ok = np.stack([inside(j[:, 0]), inside(j[:, 1])], axis=1)
            parity = np.cumsum(flip) % 2
            first = [s for s in (0, 1) if ok[0, s]] or [0]
            scores = [(int((~ok[np.arange(n), s ^ parity]).sum()),
                       float(np.abs(wrapped(j[0, s])).sum()), s) for s in first]
            s0 = min(scores)[2]
            sheet = s0 ^ parity
            for _ in range(n):  # each pass fixes one limit run: as many passes as switches
                bad = ~ok[np.arange(n), sheet] & ok[np.arange(n), 1 - sheet]
                if not bad.any():
                    break
                r = int(np.flatnonzero(bad)[0])
                flip[r] = ~flip[r]
                sheet = s0 ^ (np.cumsum(flip) % 2)
                notes.append((r, f"line {int(lines[r])}: the other solution, to stay within the "
                                 "rotary limits"))
            switches = np.flatnonzero(flip).tolist()
            for r in switches:
                if not any(r == q for q, _ in notes):
                    notes.append((r, f"line {int(lines[r])}: the other solution at the pole "
                                     "passage (the free axis keeps on instead of flipping)"))
        chosen = j[np.arange(n), sheet]
        singular = np.flatnonzero(sol.pole < POLE_DEG) if two else np.zeros(0, int)
        if two and singular.size:
            free = self.ops[0][0]
            held = sol.pole < 1e-6  # exactly at the pole the free word stays where it was
            idx = np.where(~held, np.arange(n), 0)
            idx = np.maximum.accumulate(idx)
            chosen[:, free] = np.where(held, chosen[idx, free], chosen[:, free])
            runs = np.split(singular, np.flatnonzero(np.diff(singular) > 1) + 1)
            for run in runs:
                lo_r, hi_r = int(run[0]), int(run[-1])
                notes.append((lo_r, f"lines {int(lines[lo_r])}-{int(lines[hi_r])}: tool axis "
                                    f"within {POLE_DEG:g} deg of the {self.names[free]} axis "
                                    "(singular)"))
        # continuity: unwrap each axis along the rows, then whole turns into the limits
        if start is None:
            first = wrapped(chosen[0])
        else:
            first = np.asarray(start, float) + wrapped(chosen[0] - np.asarray(start, float))
        steps = wrapped(np.diff(chosen, axis=0))
        cont = first + np.vstack([np.zeros((1, k)), np.cumsum(steps, axis=0)])
        lo, hi = self.limits[:, 0], self.limits[:, 1]
        for i in range(k):
            col = cont[:, i]
            best = None
            for m in range(-3, 4):
                shifted = col + 360.0 * m
                fit = int(((shifted >= lo[i] - 1e-9) & (shifted <= hi[i] + 1e-9)).sum())
                key = (fit, -abs(float(shifted[0])))
                if best is None or key > best[0]:
                    best = (key, m)
            cont[:, i] = col + 360.0 * best[1]
        return Choice(cont, sheet, np.asarray(switches, int), singular, sorted(notes))

    def words_for_axes(self, axis, *, start=None, lines=None, path=None,
                       tolerance: float = 1e-3) -> tuple[np.ndarray, Choice, Solutions]:
        """Continuous rotary words ``(N,k)`` for part-frame tool axes ``(N,3)`` (see `solve`,
        `choose`); an axis the chain cannot make (more than ``tolerance`` degrees away) is an
        error naming ``path`` and the line."""
        sol = self.solve(axis)
        bad = np.flatnonzero(sol.reach > tolerance)
        if bad.size:
            r = int(bad[0])
            a = np.round(np.asarray(axis, float).reshape(-1, 3)[r], 6).tolist()
            raise PathcheckError(
                f"tool axis {a} cannot be made by machine '{self.machine.name}' "
                f"({self.machine.kind}): {sol.reach[r]:.4f} deg away from the nearest axis it "
                f"can make (expected within {tolerance:g}); {bad.size} axes like it",
                path=path, line=None if lines is None else int(np.asarray(lines)[r]),
                code="kinematics")
        choice = self.choose(sol, start=start, lines=lines)
        return choice.joints, choice, sol

    # -- path length ------------------------------------------------------------------------
    def tip_path_length(self, xyz0, xyz1, j0, j1, tcp=False) -> np.ndarray:
        """Length (mm) of the tip's path relative to the part over blocks whose program xyz
        ``(N,3)`` and words ``(N,k)`` run linearly from 0 to 1, as a control does (with tcp the
        tip runs straight). Exact without rotary motion; else PATH_SUBSTEPS chords."""
        xyz0, xyz1 = np.asarray(xyz0, float), np.asarray(xyz1, float)
        j0 = np.asarray(j0, float).reshape(len(xyz0), self.k)
        j1 = np.asarray(j1, float).reshape(len(xyz0), self.k)
        length = np.linalg.norm(xyz1 - xyz0, axis=1)
        if tcp or self.k == 0:
            return length
        turning = np.flatnonzero(np.any(j0 != j1, axis=1))
        if turning.size:
            p0, dp = xyz0[turning], (xyz1 - xyz0)[turning]
            a0, da = j0[turning], (j1 - j0)[turning]
            total = np.zeros(turning.size)
            prev, _ = self.forward(p0, a0)
            for s in range(1, PATH_SUBSTEPS + 1):  # a loop over sub-steps, each over all blocks
                t = s / PATH_SUBSTEPS
                tip, _ = self.forward(p0 + t * dp, a0 + t * da)
                total += np.linalg.norm(tip - prev, axis=1)
                prev = tip
            length[turning] = total
        return length


# -- the 4-axis B-table helpers (docs/MATH.md §1), kept for callers of the older API -------------
def axis_from_rotation(theta: np.ndarray) -> np.ndarray:
    """Part-frame tool axis ``(N, 3)`` of a B table for part rotations ``theta (N,)`` radians:
    ``(-sin b, 0, cos b)``."""
    return axis_for_b(np.degrees(theta))


def rotation_from_axis(axis, *, j_tolerance: float = 1e-6, lines=None, path=None) -> np.ndarray:
    """Part rotation ``b (N,)`` degrees about +Y that puts part-frame axes ``(N, 3)`` along the
    spindle: ``b = atan2(-i, k)``; ``|j| > j_tolerance`` is an error naming the line."""
    axis = np.asarray(axis, dtype=float)
    check_four_axis(axis, lines, path, j_tolerance)
    return b_for_axis(axis)
