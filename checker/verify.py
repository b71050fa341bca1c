"""The real tool at the real pose: how deep the tool (the cutter's body, its shank and holder)
goes into the part at every pose a job's moves pass through, and along every move, against the
part's triangles (`geometry.tessellate`) with the exact tests of `checker.mesh`.

Along a move the depth is bounded between checked poses. The depth is a signed distance
between the tool and the part, so moving the tool changes it by at most the distance its points
travel: over a stretch of a move on which the tool's points (those that can reach the part)
travel at most L, with depths da and db at its ends, no pose is deeper than (da + db + L) / 2
(the two cones from the ends meet there). Stretches whose bound is above the tolerance are
halved and their middles checked, until every stretch is certified within the tolerance or
the move's deepest pose is found to a fraction of it (`along_moves`). A move in the air is
certified from its clearances in a few halvings. In contact that bound would need stretches of
about twice the tolerance; there a stretch is first certified whole against the part swept
along it (`checker.mesh.swept`: exact for a translation, with a slack for the tool's turning,
`stretches`), and only the stretches that fail are halved, so a move sliding along the part
needs a few poses instead of one per tolerance. A multi-axis move on a 5-axis machine runs the
machine's joints linearly (`checker.five_axis.motion`, which gives its poses and its L); it is
halved the same way. mm, part frame (docs/MATH.md §8.1)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from checker.b_axis import axis_for_b, rotate_about_y
from checker.moves import START, Moves
from checker.progress import step

_MAX_ROUNDS = 60  # halvings at most (2^-60 of a move: far below any tolerance)
_DEPTH_PRECISION = 0.1  # a move's deepest pose is found to this fraction of its depth


@dataclass(frozen=True)
class Depths:
    """Per checked pose: `depth` mm (> 0: penetration; < 0: clearance, capped at the reach),
    `piece` of the tool that reaches deepest (0 body, 1 shank, 2 holder; -1 clear), `point`
    (3,) the deepest (or nearest) point of the part, `triangle` its triangle, `height` its
    height above the tool tip along the axis (mm)."""

    depth: np.ndarray
    piece: np.ndarray
    point: np.ndarray
    triangle: np.ndarray
    height: np.ndarray

    @staticmethod
    def empty(n: int) -> Depths:
        return Depths(np.full(n, -np.inf), np.full(n, -1, dtype=np.int64),
                      np.full((n, 3), np.nan), np.full(n, -1, dtype=np.int64), np.full(n, np.nan))

    def put(self, rows: np.ndarray, other: Depths, idx: np.ndarray | slice = slice(None)) -> None:
        """Rows `rows` of this one from rows `idx` of `other` (in place)."""
        self.depth[rows] = other.depth[idx]
        self.piece[rows] = other.piece[idx]
        self.point[rows] = other.point[idx]
        self.triangle[rows] = other.triangle[idx]
        self.height[rows] = other.height[idx]


class PoseProbe:
    """Depths of poses of one tool against the part: `(tips (N, 3), axes (N, 3)) -> Depths`,
    through `checker.mesh.pose_depths` with the tool's pieces, clearances capped at `reach`."""

    def __init__(self, index, pieces, reach: float) -> None:
        self.index, self.pieces, self.reach = index, pieces, float(reach)

    def __call__(self, tips: np.ndarray, axes: np.ndarray) -> Depths:
        from checker.mesh.depth import pose_depths

        r = pose_depths(self.index, self.pieces, np.ascontiguousarray(tips, dtype=float),
                        np.ascontiguousarray(axes, dtype=float), reach=self.reach)
        height = np.einsum("ij,ij->i", r.point - tips, axes)
        return Depths(np.asarray(r.depth, float), np.asarray(r.piece, np.int64),
                      np.asarray(r.point, float), np.asarray(r.triangle, np.int64), height)

    def certify(self, ref: Stretches, tolerance: np.ndarray) -> np.ndarray:
        """(S,) bool: no pose of stretch s goes deeper than `tolerance[s]` mm
        (`checker.mesh.swept`)."""
        from checker.mesh.swept import certified_stretches

        return certified_stretches(self.index, self.pieces, ref.mids, ref.axes, ref.half,
                                   ref.tau, ref.alpha, tolerance)


@dataclass(frozen=True)
class MoveDepths:
    """Per move (ending at pose `end`): the deepest of its poses (`depths`, the end poses
    excluded: they are checked as poses), `t` in (0, 1) where along the move, `tip` and `axis`
    there, and how many poses were checked along it."""

    end: np.ndarray
    depths: Depths
    t: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    poses: np.ndarray


def _machine_ends(moves: Moves, end: np.ndarray, b: np.ndarray, center: np.ndarray):
    """The machine tips X at both ends of the moves ending at `end`, table angles `b` (per pose,
    degrees): the part-frame tips turned with the table about Y through `center`."""
    return (rotate_about_y(moves.tip[end - 1], b[end - 1], center),
            rotate_about_y(moves.tip[end], b[end], center))


def _on_table(ma: np.ndarray, me: np.ndarray, ba: np.ndarray, be: np.ndarray, t: np.ndarray,
              center: np.ndarray):
    """(tips, axes) in the part frame at fraction t of machine moves running linearly in X, Y, Z
    from `ma` to `me` and in B from `ba` to `be` (degrees)."""
    bt = ba + t * (be - ba)
    return rotate_about_y(ma + t[:, None] * (me - ma), -bt, center), axis_for_b(bt)


def pose_at(moves: Moves, end: np.ndarray, t: np.ndarray, b: np.ndarray | None,
             center: np.ndarray):
    """(tips, axes) at fraction t of the moves ending at `end`. With table angles `b` (per pose,
    degrees) the machine moves linearly in X, Y, Z and B (the part turns about Y through
    `center`); otherwise the tool translates with its axis turning linearly."""
    a, e = end - 1, end
    if b is None:
        tip = moves.tip[a] + t[:, None] * (moves.tip[e] - moves.tip[a])
        ax = moves.axis[a] + t[:, None] * (moves.axis[e] - moves.axis[a])
        return tip, ax / np.linalg.norm(ax, axis=1)[:, None]
    return _on_table(*_machine_ends(moves, end, b, center), b[a], b[e], t, center)


class Stretches(NamedTuple):
    """Reference motions of S stretches of moves (`checker.mesh.swept`): the tool at unit axis
    `axes (S, 3)` translating from tip `mids - half` to `mids + half` (S, 3; mm, part frame);
    the real poses leave it by at most `tau (S,)` mm at the tip and `alpha (S,)` radians."""

    mids: np.ndarray
    axes: np.ndarray
    half: np.ndarray
    tau: np.ndarray
    alpha: np.ndarray


def stretches(moves: Moves, end: np.ndarray, t0: np.ndarray, t1: np.ndarray,
              b: np.ndarray | None, center: np.ndarray) -> Stretches:
    """The reference motions of the stretches t0..t1 of the moves ending at `end`: the chord of
    the tips at the middle axis. A tool translating with its axis turning linearly follows the
    chord (tau = 0) and turns from the middle axis by less than to the end axes. The table
    turning by dθ over a stretch (radians) while the machine tip X runs straight by |ΔX|: the
    part-frame tip X(s) turned by -B(s) bends by |p''| <= dθ^2 |X - c| + 2 dθ |ΔX| (|X - c|
    from the table's axis, largest at an end), at most |p''| / 8 off its chord; the axis is
    within dθ / 2 of the middle one."""
    tm = 0.5 * (t0 + t1)
    if b is None:
        tip0, ax0 = pose_at(moves, end, t0, b, center)
        tip1, ax1 = pose_at(moves, end, t1, b, center)
        _, axm = pose_at(moves, end, tm, b, center)
        cos = np.minimum(np.einsum("ij,ij->i", ax0, axm), np.einsum("ij,ij->i", ax1, axm))
        return Stretches(0.5 * (tip0 + tip1), axm, 0.5 * (tip1 - tip0), np.zeros(len(end)),
                         np.arccos(np.clip(cos, -1.0, 1.0)))
    a, e = end - 1, end
    ma, me = _machine_ends(moves, end, b, center)
    tip0, _ = _on_table(ma, me, b[a], b[e], t0, center)
    tip1, _ = _on_table(ma, me, b[a], b[e], t1, center)
    _, axm = _on_table(ma, me, b[a], b[e], tm, center)
    mids, half = 0.5 * (tip0 + tip1), 0.5 * (tip1 - tip0)
    dt = t1 - t0
    turn = np.radians(np.abs(b[e] - b[a])) * dt
    run = np.linalg.norm(me - ma, axis=1) * dt
    xa, xb = ma + t0[:, None] * (me - ma), ma + t1[:, None] * (me - ma)
    arm = np.maximum(np.hypot(xa[:, 0] - center[0], xa[:, 2] - center[2]),
                     np.hypot(xb[:, 0] - center[0], xb[:, 2] - center[2]))
    return Stretches(mids, axm, half, (turn ** 2 * arm + 2.0 * turn * run) / 8.0, 0.5 * turn)


def move_lengths(moves: Moves, end: np.ndarray, box: np.ndarray, b: np.ndarray | None = None,
                 center: np.ndarray | None = None) -> np.ndarray:
    """(M,) mm: how far any point of the tool that can touch the part (a point inside the
    part's box `box (2, 3)`, grown by the reach) travels along each move, at most. The tool
    translating and its axis turning by dθ: |Δtip| + dθ times the farthest such point from the
    tip. The table turning by dB (machine-linear moves): |Δ machine tip| + dB times the
    farthest point of the box from the table's axis (Y through `center`).

    The axis turning "linearly" is the normalised chord between the end axes: over an angle θ
    its rate peaks at 2 tan(θ/2) (at the middle), which stands in for dθ; the tip runs
    straight, so the farthest point is measured from both end tips (the distance to a point of
    a segment is largest at an end)."""
    a = end - 1
    corners = np.array([[box[i, 0], box[j, 1], box[k, 2]] for i in (0, 1) for j in (0, 1)
                        for k in (0, 1)])
    if b is None:
        cos = np.clip(np.einsum("ij,ij->i", moves.axis[a], moves.axis[end]), -1.0, 1.0)
        turn = 2.0 * np.tan(0.5 * np.minimum(np.arccos(cos), np.pi - 1e-6))
        far = np.maximum(
            np.linalg.norm(corners[None] - moves.tip[a][:, None], axis=2).max(axis=1),
            np.linalg.norm(corners[None] - moves.tip[end][:, None], axis=2).max(axis=1))
        return np.linalg.norm(moves.tip[end] - moves.tip[a], axis=1) + turn * far
    c = np.zeros(3) if center is None else center
    far = np.hypot(corners[:, 0] - c[0], corners[:, 2] - c[2]).max()
    shift = (rotate_about_y(moves.tip[end], b[end], c) - rotate_about_y(moves.tip[a], b[a], c))
    return np.linalg.norm(shift, axis=1) + np.radians(np.abs(b[end] - b[a])) * far


@dataclass(frozen=True)
class ProgramMotion:
    """The poses and moves of a program as the machine makes them: `moves`, the operation of
    each pose `op_of (P,)`, the table angle B of each pose `b (P,)` (degrees, nan: none) turning
    the part about Y through `center`, and `path` (a `checker.five_axis.motion.MachinePath`
    over the poses) for the operations `five_ops` whose joints run linearly."""

    moves: Moves
    op_of: np.ndarray
    b: np.ndarray
    center: np.ndarray
    path: object = None
    five_ops: frozenset[int] = frozenset()

    def table(self, ends: np.ndarray) -> np.ndarray | None:
        """The B per pose when every move ending at `ends` turns the table, else None."""
        return self.b if len(ends) and np.isfinite(self.b[ends]).all() else None

    def machine(self, op: int):
        """The operation's `MachinePath` when its joints run linearly, else None."""
        return self.path if self.path is not None and op in self.five_ops else None


def tool_depths(index, box: np.ndarray, motion: ProgramMotion, pieces: dict,
                tolerance: np.ndarray, reach: float) -> tuple[Depths, MoveDepths]:
    """The real tool (`pieces[op]`, `checker.mesh.tool.ToolPieces`) against the triangles of
    `index` (within the box `box (2, 3)`, grown by the reach) at every pose of `motion` and
    along every move (`along_moves`), `tolerance (P,)` mm per pose."""
    moves = motion.moves
    poses = Depths.empty(len(moves))
    parts = []
    for o in np.unique(motion.op_of):
        probe = PoseProbe(index, pieces[int(o)], reach)
        P = np.flatnonzero(motion.op_of == o)
        poses.put(P, probe(moves.tip[P], moves.axis[P]))
        ends = P[moves.kind[P] != START]
        parts.append(along_moves(probe, moves, ends, poses.depth, tolerance[ends], box,
                                 motion.table(ends), motion.center,
                                 motion=motion.machine(int(o))))
    return poses, concat_moves(parts, len(moves))


def concat_moves(parts: list[MoveDepths], n: int) -> MoveDepths:
    """The moves of all operations in pose order."""
    if not parts:
        z = np.zeros(0, dtype=np.int64)
        return MoveDepths(z, Depths.empty(0), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), z)
    end = np.concatenate([p.end for p in parts])
    order = np.argsort(end, kind="stable")
    cat = lambda f: np.concatenate([f(p) for p in parts])[order]  # noqa: E731
    d = Depths(cat(lambda p: p.depths.depth), cat(lambda p: p.depths.piece),
               cat(lambda p: p.depths.point), cat(lambda p: p.depths.triangle),
               cat(lambda p: p.depths.height))
    return MoveDepths(end[order], d, cat(lambda p: p.t), cat(lambda p: p.tip),
                      cat(lambda p: p.axis), cat(lambda p: p.poses))


def along_moves(probe: PoseProbe, moves: Moves, end: np.ndarray, end_depths: np.ndarray,
                tolerance: np.ndarray, box: np.ndarray, b: np.ndarray | None = None,
                center: np.ndarray | None = None, precision: float = 0.25,
                motion=None) -> MoveDepths:
    """The deepest pose along each move ending at poses `end` (see the module docstring):
    `end_depths (P,)` the depths at all poses, `tolerance (M,)` mm. A stretch of a move between
    two checked poses with depths da, db and length L (mm, `move_lengths`) cannot go deeper
    than (da + db + L) / 2 (the depth changes by at most the distance moved); stretches whose
    bound exceeds the tolerance, and the deepest depth found on the move by more than
    `precision` times the tolerance and _DEPTH_PRECISION times that depth, are split at their
    middle and checked again: a move is certified within the tolerance, or its deepest pose is
    found to that precision. `motion` (a `checker.five_axis.motion.MachinePath` over these
    poses) moves the machine's joints linearly instead, with its own bound on L."""
    center = np.zeros(3) if center is None else np.asarray(center, float)
    m = len(end)
    best = Depths.empty(m)
    t_best = np.full(m, np.nan)
    tip_best, axis_best = np.full((m, 3), np.nan), np.full((m, 3), np.nan)
    length = (move_lengths(moves, end, box, b, center) if motion is None
              else motion.lengths(end, box))
    count = np.zeros(m, dtype=np.int64)
    ends = np.maximum(end_depths[end - 1], end_depths[end])  # the deepest known at the ends
    # the open stretches: move k, from t0 to t1 with depths d0, d1 there
    k = np.flatnonzero(length > 0.0)
    t0, t1 = np.zeros(len(k)), np.ones(len(k))
    d0, d1 = end_depths[end[k] - 1], end_depths[end[k]]
    with step("check along the moves") as advance:
        for _ in range(_MAX_ROUNDS):
            bound = 0.5 * (d0 + d1 + (t1 - t0) * length[k])
            known = np.maximum(best.depth[k], ends[k])
            slack = np.maximum(precision * tolerance[k], _DEPTH_PRECISION * known)
            open_ = (bound > tolerance[k]) & (bound > known + slack)
            k, t0, t1, d0, d1 = k[open_], t0[open_], t1[open_], d0[open_], d1[open_]
            if k.size and motion is None:  # a stretch certified whole needs no halving
                open_ = ~probe.certify(stretches(moves, end[k], t0, t1, b, center), tolerance[k])
                k, t0, t1, d0, d1 = k[open_], t0[open_], t1[open_], d0[open_], d1[open_]
            if k.size == 0:
                break
            tm = 0.5 * (t0 + t1)
            tips, axes = (pose_at(moves, end[k], tm, b, center) if motion is None
                          else motion.pose_at(end[k], tm))
            got = probe(tips, axes)
            advance(1)
            np.add.at(count, k, 1)
            order = np.lexsort((-got.depth, k))  # per move its deepest new pose first
            first = order[np.r_[True, k[order][1:] != k[order][:-1]]]
            take = first[got.depth[first] > best.depth[k[first]]]
            rows = k[take]
            best.put(rows, got, take)
            t_best[rows], tip_best[rows], axis_best[rows] = tm[take], tips[take], axes[take]
            k = np.r_[k, k]
            t0, t1 = np.r_[t0, tm], np.r_[tm, t1]
            d0, d1 = np.r_[d0, got.depth], np.r_[got.depth, d1]
    return MoveDepths(end, best, t_best, tip_best, axis_best, count)

