"""G-code moves back into the part frame: B words resolved by the machine's wrap mode, arcs cut
into chords, the machine kinematics inverted, and the tip speed relative to the part recovered
from F (G94 by the dialect's feed-distance rule, G93 as inverse time, G95 per revolution)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError
from checker.toolpath import MotionArrays, Operation, ToolPath
from postproc.dialects import get_dialect
from postproc.kinematics import machine_to_part, tip_path_length
from postproc.machine import Machine
from postproc.reader import CYCLE, MM_PER_INCH, PROGRAMMED, GcodeMoves
from postproc.wrap import unroll_rollover


@dataclass(frozen=True)
class PartMotions:
    """Tool positions in the part frame, one row per block end (arcs: per chord end).
    ``tip (N,3)`` mm, ``axis (N,3)`` unit (tip -> spindle), ``b_deg (N,)`` part rotation about
    +Y, ``rapid (N,)``, ``feed (N,)`` tip speed relative to the part mm/min (nan: rapid or
    unknown), ``line (N,)`` program line, ``tool (N,)``, ``known (N,)`` the position is known in
    the work frame (not after G28/G53 until the axes are programmed again)."""

    tip: np.ndarray
    axis: np.ndarray
    b_deg: np.ndarray
    rapid: np.ndarray
    feed: np.ndarray
    line: np.ndarray
    tool: np.ndarray
    known: np.ndarray

    def __len__(self) -> int:
        return len(self.line)


def table_position(moves: GcodeMoves, machine: Machine) -> np.ndarray:
    """Continuous table position ``(N,)`` degrees the control reaches for the program's B words
    (rollover axes unrolled the shorter or the signed way; B never programmed counts as 0)."""
    words = np.nan_to_num(moves.abc[:, 1], nan=0.0)
    if machine.rotary.word_range() is None:
        return unroll_rollover(
            words, machine.rotary.wrap, start=float(words[0]) if len(words) else 0.0
        )
    return words


def _check_axes(moves: GcodeMoves, machine: Machine) -> None:
    for k, name in ((0, "A"), (2, "C")):
        used = np.flatnonzero(np.nan_to_num(moves.abc[:, k]) != 0.0)
        if used.size:
            raise PathcheckError(
                f"the program turns {name} ({name}{moves.abc[used[0], k]:g}); machine "
                f"'{machine.name}' has only a B table: expected {name} unused or 0",
                path=moves.path,
                line=int(moves.line[used[0]]),
                code="kinematics",
            )


def _chords(moves: GcodeMoves, turn: np.ndarray, tolerance: float):
    """Block ends with arcs split into chords of sagitta <= tolerance (mm): end points ``(M,3)``,
    table positions ``(M,)``, the row each came from ``(M,)`` and the chord count of that row."""
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
    with np.errstate(invalid="ignore", divide="ignore"):
        step = 2 * np.arccos(np.clip(1 - tolerance / radius, -1.0, 1.0))
        count = np.where(arc, np.maximum(1, np.ceil(np.abs(sweep) / np.maximum(step, 1e-6))), 1)
    count = count.astype(int)
    src = np.repeat(rows, count)
    j = np.arange(src.size) - np.repeat(np.cumsum(count) - count, count) + 1
    t = j / count[src]
    prev_turn = np.concatenate([turn[:1], turn[:-1]])
    pts = start[src] + t[:, None] * (moves.xyz[src] - start[src])  # lines and the helix axis
    on_arc = arc[src]
    ang = a0[src] + t * sweep[src]
    k = uvw[src]
    idx = np.flatnonzero(on_arc)
    pts[idx, k[idx, 0]] = moves.center[src[idx], k[idx, 0]] + radius[src[idx]] * np.cos(ang[idx])
    pts[idx, k[idx, 1]] = moves.center[src[idx], k[idx, 1]] + radius[src[idx]] * np.sin(ang[idx])
    pts[j == count[src]] = moves.xyz[src[j == count[src]]]
    turns = prev_turn[src] + t * (turn[src] - prev_turn[src])
    return pts, turns, src, count


def part_motions(
    moves: GcodeMoves, machine: Machine, *, chord_tolerance: float = 0.01
) -> PartMotions:
    """The program's tool positions in the part frame for ``machine`` (see PartMotions)."""
    _check_axes(moves, machine)
    turn = table_position(moves, machine)
    xyz, turns, src, count = _chords(moves, turn, chord_tolerance)
    tip, axis = machine_to_part(xyz, turns, machine)
    b_deg = machine.kinematics.b_direction * turns
    known = np.isfinite(xyz).all(axis=1) & np.isin(moves.kind[src], (PROGRAMMED, CYCLE))
    prev_known = np.concatenate([[False], known[:-1]])
    xyz0 = np.vstack([xyz[:1], xyz[:-1]])
    turn0 = np.concatenate([turns[:1], turns[:-1]])
    length = tip_path_length(np.nan_to_num(xyz0), np.nan_to_num(xyz), turn0, turns, machine)
    f = moves.feed[src]
    mode = moves.feed_mode[src]
    scale = MM_PER_INCH if moves.units == "inch" else 1.0
    dist = get_dialect(moves.dialect).feed_distance((xyz - xyz0) / scale, turns - turn0)
    with np.errstate(invalid="ignore", divide="ignore"):
        minutes = np.select(
            [mode == 94, mode == 93],
            [dist / (f / scale), 1.0 / (f * count[src])],
            default=length / (f * np.abs(moves.spindle[src])),
        )
        speed = length / minutes
    rapid = moves.motion[src] == 0
    feed = np.where(~rapid & known & prev_known & np.isfinite(speed), speed, np.nan)
    return PartMotions(
        tip=tip,
        axis=axis,
        b_deg=b_deg,
        rapid=rapid,
        feed=feed,
        line=moves.line[src],
        tool=moves.tool[src],
        known=known,
    )


def toolpath_of(motions: PartMotions, *, path: str | Path, units: str, cutter) -> ToolPath:
    """The program's moves as an in-memory tool path (one operation with `cutter`), so that
    `checker.job.check_toolpath` checks a G-code program like a CL file. Positions the program
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
