"""G-code moves back into the part frame: rotary words resolved by each axis's wrap mode, arcs cut
into chords, the machine's forward kinematics (from its chain; work-frame tips where the program
runs with tool-centre-point control or in a tilted plane), and the tip speed relative to the part
recovered from F (G94 by the dialect's feed-distance rule, G93 as inverse time, G95 per
revolution at the spindle speed in force)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.b_axis import b_for_axis
from checker.errors import PathcheckError
from checker.input_limits import MAX_PROGRAM_POINTS
from checker.postproc.dialects import get_dialect
from checker.postproc.kinematics import Chain
from checker.postproc.machine import Machine
from checker.postproc.reader import CYCLE, PROGRAMMED, GcodeMoves
from checker.postproc.wrap import unroll_rollover
from checker.toolpath import MotionArrays, Operation, ToolPath
from checker.units import mm_per_unit

_LETTERS = "ABC"


@dataclass(frozen=True)
class PartMotions:
    """Tool positions in the part frame, one row per block end (arcs: per chord end; blocks
    turning a rotary axis: per step).
    ``tip (N,3)`` mm, ``axis (N,3)`` unit (tip -> spindle), ``b_deg (N,)`` the part rotation
    about +Y that gives the axis (b of docs/MATH.md §1; meaningful for 4-axis B tables),
    ``joints (N,k)`` the machine's rotary positions (deg, continuous, ``names`` order),
    ``xyz (N,3)`` program X Y Z (work frame mm), ``tcp (N,)`` those are work-frame tips,
    ``rapid (N,)``, ``feed (N,)`` tip speed relative to the part mm/min (nan: rapid or
    unknown), ``minutes (N,)`` block time (nan unknown), ``line (N,)`` program line,
    ``tool (N,)``, ``known (N,)`` the position is known (not after G28/G53 until the axes are
    programmed again, nor at unknown words)."""

    tip: np.ndarray
    axis: np.ndarray
    b_deg: np.ndarray
    rapid: np.ndarray
    feed: np.ndarray
    line: np.ndarray
    tool: np.ndarray
    known: np.ndarray
    joints: np.ndarray | None = None
    names: tuple[str, ...] = ()
    xyz: np.ndarray | None = None
    tcp: np.ndarray | None = None
    minutes: np.ndarray | None = None
    feed_mode: np.ndarray | None = None
    block: np.ndarray | None = None  # (N,) the motion row (block) each row belongs to
    end: np.ndarray | None = None  # (N,) the row ends its block

    def __len__(self) -> int:
        return len(self.line)

    def block_feed(self) -> np.ndarray:
        """``(N,)`` the tip speed relative to the part averaged over each row's whole block
        (path length / block time, mm/min; nan where unknown): the feed the program asked for,
        where ``feed`` is the speed over each piece (it varies along a block that turns a rotary
        axis without tool-centre-point control)."""
        ok = np.isfinite(self.feed) & np.isfinite(self.minutes)
        length = np.where(ok, self.feed * np.where(ok, self.minutes, 0.0), 0.0)
        n = int(self.block.max()) + 1 if len(self.block) else 0
        total_l = np.bincount(self.block, weights=length, minlength=n)
        total_t = np.bincount(self.block, weights=np.where(ok, self.minutes, 0.0), minlength=n)
        bad = np.bincount(self.block, weights=(~ok).astype(float), minlength=n) > 0
        with np.errstate(invalid="ignore", divide="ignore"):
            avg = np.where(bad | (total_t <= 0), np.nan, total_l / total_t)
        return avg[self.block]


def _rotary_words(moves: GcodeMoves, machine: Machine) -> np.ndarray:
    """Rotary words ``(N,k)`` in the machine's axis order: NaN before an axis is first
    programmed counts as 0; NaN after (an unknown value) stays NaN. A word for an axis the
    machine lacks is an error naming the line."""
    names = [a.name for a in machine.rotary_axes]
    for k, name in enumerate(_LETTERS):
        if name in names:
            continue
        used = np.flatnonzero(np.nan_to_num(moves.abc[:, k]) != 0.0)
        if used.size:
            raise PathcheckError(
                f"the program turns {name} ({name}{moves.abc[used[0], k]:g}); machine "
                f"'{machine.name}' ({machine.kind}) has no {name} axis: expected {name} unused "
                "or 0",
                path=moves.path,
                line=int(moves.line[used[0]]),
                code="kinematics",
            )
    out = np.zeros((len(moves), len(names)))
    for j, name in enumerate(names):
        col = moves.abc[:, _LETTERS.index(name)]
        finite = np.isfinite(col)
        before = np.arange(len(col)) < (np.argmax(finite) if finite.any() else len(col))
        out[:, j] = np.where(before, 0.0, col)
    return out


def table_position(moves: GcodeMoves, machine: Machine) -> np.ndarray:
    """Continuous rotary positions ``(N,k)`` degrees the control reaches for the program's words
    (rollover axes unrolled the shorter or the signed way)."""
    words = _rotary_words(moves, machine)
    out = words.copy()
    for j, axis in enumerate(machine.rotary_axes):
        if axis.word_range() is None:
            col = words[:, j]
            ok = np.isfinite(col)
            if ok.any():
                start = float(col[ok][0])
                out[ok, j] = unroll_rollover(col[ok], axis.wrap, start=start)
    return out


def _chords(moves: GcodeMoves, turn: np.ndarray, tolerance: float, rotary_step: float):
    """Block ends with arcs split into chords of sagitta <= tolerance (mm) and blocks that turn
    a rotary axis split every ``rotary_step`` degrees (X Y Z and the words run linearly, as the
    control moves them: the part-frame path between is the real, curved one): end points
    ``(M,3)``, rotary positions ``(M,k)``, the row each came from ``(M,)`` and the piece count of
    that row."""
    n = len(moves)
    start = np.vstack([moves.xyz[:1], moves.xyz[:-1]]) if n else moves.xyz
    arc = np.isin(moves.motion, (2, 3)) & np.isfinite(moves.center).all(axis=1)
    planes = np.array([(0, 1, 2), (2, 0, 1), (1, 2, 0)])  # G17, G18, G19: (u, v, normal)
    uvw = planes[moves.plane - 17].reshape(n, 3)
    rows = np.arange(n)
    su, sv = (
        start[rows, uvw[:, 0]] - moves.center[rows, uvw[:, 0]],
        start[rows, uvw[:, 1]] - moves.center[rows, uvw[:, 1]],
    )
    eu, ev = (
        moves.xyz[rows, uvw[:, 0]] - moves.center[rows, uvw[:, 0]],
        moves.xyz[rows, uvw[:, 1]] - moves.center[rows, uvw[:, 1]],
    )
    radius = np.hypot(su, sv)
    a0, a1 = np.arctan2(sv, su), np.arctan2(ev, eu)
    ccw = moves.motion == 3
    sweep = np.where(ccw, np.mod(a1 - a0, 2 * np.pi), -np.mod(a0 - a1, 2 * np.pi))
    sweep = np.where(arc & (np.abs(sweep) < 1e-12), np.where(ccw, 2 * np.pi, -2 * np.pi), sweep)
    if moves.arc_turns is not None:  # LinuxCNC's P: P - 1 full turns before the arc's own
        extra = np.where(arc, moves.arc_turns - 1, 0)
        sweep = sweep + np.where(ccw, 2 * np.pi, -2 * np.pi) * extra
    with np.errstate(invalid="ignore", divide="ignore"):
        step = 2 * np.arccos(np.clip(1 - tolerance / radius, -1.0, 1.0))
        count = np.where(arc, np.maximum(1, np.ceil(np.abs(sweep) / np.maximum(step, 1e-6))), 1)
    prev_turn = np.vstack([turn[:1], turn[:-1]])
    rot = np.nan_to_num(np.abs(turn - prev_turn)).max(axis=1, initial=0.0)
    placed = np.isfinite(start).all(axis=1) & np.isfinite(moves.xyz).all(axis=1)
    count = np.where(placed, np.maximum(count, np.ceil(rot / rotary_step - 1e-9)), count)
    count = np.clip(count, 1, 100000).astype(int)
    if count.sum() > MAX_PROGRAM_POINTS:  # bounded in total, not only per block
        worst = int(np.argmax(count))
        raise PathcheckError(
            f"the program's arcs and rotary turns expand into {int(count.sum()):,} positions "
            f"(this block alone {int(count[worst]):,}), more than {MAX_PROGRAM_POINTS:,}: "
            "expected arcs and turns a machine makes", path=moves.path,
            line=int(moves.line[worst]), code="gcode")
    src = np.repeat(rows, count)
    j = np.arange(src.size) - np.repeat(np.cumsum(count) - count, count) + 1
    t = j / count[src]
    pts = start[src] + t[:, None] * (moves.xyz[src] - start[src])  # lines and the helix axis
    on_arc = arc[src]
    ang = a0[src] + t * sweep[src]
    k = uvw[src]
    idx = np.flatnonzero(on_arc)
    pts[idx, k[idx, 0]] = moves.center[src[idx], k[idx, 0]] + radius[src[idx]] * np.cos(ang[idx])
    pts[idx, k[idx, 1]] = moves.center[src[idx], k[idx, 1]] + radius[src[idx]] * np.sin(ang[idx])
    pts[j == count[src]] = moves.xyz[src[j == count[src]]]
    turns = prev_turn[src] + t[:, None] * (turn[src] - prev_turn[src])
    return pts, turns, src, count


def part_motions(
    moves: GcodeMoves, machine: Machine, *, chord_tolerance: float = 0.01,
    rotary_step: float = 1.0,
) -> PartMotions:
    """The program's tool positions in the part frame for ``machine`` (see PartMotions): arcs in
    chords of sagitta ``chord_tolerance`` mm, blocks turning a rotary axis in steps of at most
    ``rotary_step`` degrees."""
    chain = Chain(machine)
    turn = table_position(moves, machine)
    xyz, turns, src, count = _chords(moves, turn, chord_tolerance, rotary_step)
    n = len(moves)
    tcp = moves.tcp if moves.tcp is not None else np.zeros(n, bool)
    tool_axis = moves.tool_axis if moves.tool_axis is not None else np.full((n, 3), np.nan)
    tcp_rows = tcp[src]
    safe_j = np.nan_to_num(turns)
    tip, axis = chain.forward(np.nan_to_num(xyz), safe_j, tcp_rows)
    tilted = np.isfinite(tool_axis[src]).all(axis=1)
    axis[tilted] = tool_axis[src][tilted] @ chain.rot
    known_axis = np.isfinite(turns).all(axis=1) | tilted
    tip[~np.isfinite(xyz).all(axis=1)] = np.nan
    known = (np.isfinite(xyz).all(axis=1) & known_axis
             & np.isin(moves.kind[src], (PROGRAMMED, CYCLE)))
    prev_known = np.concatenate([[False], known[:-1]])
    xyz0 = np.vstack([xyz[:1], xyz[:-1]])
    turn0 = np.vstack([turns[:1], turns[:-1]])
    length = np.linalg.norm(np.nan_to_num(tip) - np.nan_to_num(np.vstack([tip[:1], tip[:-1]])),
                            axis=1)
    turning = ~tcp_rows & np.any(turn0 != turns, axis=1) & known & prev_known
    if turning.any():
        length[turning] = chain.tip_path_length(xyz0[turning], xyz[turning],
                                                turn0[turning], turns[turning])
    f = moves.feed[src]
    mode = moves.feed_mode[src]
    scale = mm_per_unit(moves.units)
    rule = get_dialect(moves.dialect).feed_distance
    dxyz, dturn = (xyz - xyz0) / scale, turns - turn0
    dist = np.where(tcp_rows, rule(dxyz, dturn, True), rule(dxyz, dturn, False))
    with np.errstate(invalid="ignore", divide="ignore"):
        minutes = np.select(
            [mode == 94, mode == 93],
            [dist / (f / scale), 1.0 / (f * count[src])],
            default=length / (f * np.abs(moves.spindle[src])),
        )
        speed = length / minutes
    rapid = moves.motion[src] == 0
    ok = ~rapid & known & prev_known
    feed = np.where(ok & np.isfinite(speed), speed, np.nan)
    return PartMotions(
        tip=tip,
        axis=axis,
        b_deg=b_for_axis(axis),
        rapid=rapid,
        feed=feed,
        line=moves.line[src],
        tool=moves.tool[src],
        known=known,
        joints=turns,
        names=chain.names,
        xyz=xyz,
        tcp=tcp_rows,
        minutes=np.where(ok, minutes, np.nan),
        feed_mode=mode,
        block=src,
        end=np.concatenate([src[1:] != src[:-1], [True]]) if len(src) else np.zeros(0, bool),
    )


def toolpath_of(motions: PartMotions, *, path: str | Path, units: str, cutter) -> ToolPath:
    """The program's moves as an in-memory tool path (one operation with `cutter`), so that
    `checker.check.check_toolpath` checks a G-code program like a CL file. Positions the program
    leaves undefined (before the first full X Y Z) are dropped."""
    keep = np.flatnonzero(motions.known)
    n = keep.size
    arrays = MotionArrays(
        tip=motions.tip[keep],
        axis=motions.axis[keep],
        rapid=motions.rapid[keep],
        feed=motions.feed[keep],
        spindle=np.full(n, np.nan),
        line=motions.line[keep],
        op=np.zeros(n, dtype=np.int64),
        cycle=np.zeros(n, dtype=bool),
        arc=np.full(n, -1, dtype=np.int64),
        coolant=np.full(n, -1, dtype=np.int64),
    )
    operation = Operation(name=Path(path).stem, cutter=cutter, end_motion=n)
    return ToolPath(path=str(path), dialect="gcode", units=units, records=[],
                    operations=[operation], motions=arrays)
