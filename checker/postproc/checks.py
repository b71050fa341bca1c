"""Machine checks of a program read back (`pathcheck check-gcode`): travel of the linear axes in
machine coordinates, rotary limits and wraps, singular passages (the free axis swinging near the
pole), and the feed of the linear and rotary axes against the machine's maxima. Each check is
vectorised over all rows; a finding names its first program line, how many rows, and the worst
value."""

from __future__ import annotations

import numpy as np

from checker.postproc.kinematics import POLE_DEG, Chain
from checker.postproc.machine import Machine
from checker.postproc.reader import GcodeMoves
from checker.postproc.replay import PartMotions

#: a free-axis swing larger than this (deg) in one block near the pole is a singular passage
FLIP_DEG = 20.0


def _finding(check: str, rows: np.ndarray, lines: np.ndarray, message: str,
             unit: str = "blocks") -> dict:
    """One finding: its first program line, how many ``unit`` (blocks, or points along them),
    the message."""
    first = int(rows[0])
    return {"check": check, "line": int(lines[first]), "count": int(rows.size),
            "message": f"line {int(lines[first])}: {message}"
                       + (f" ({rows.size} {unit} like it)" if rows.size > 1 else "")}


def _per_block(motions: PartMotions, joints: np.ndarray) -> np.ndarray:
    """``(N,k)`` how far each rotary axis turns over the whole block of each row (rows of one
    block are its pieces: arc chords, rotary steps)."""
    if motions.block is None or not len(joints):
        return np.abs(np.diff(joints, axis=0, prepend=joints[:1]))
    ends = np.flatnonzero(motions.end)
    at_end = joints[ends]
    turn = np.abs(np.diff(at_end, axis=0, prepend=at_end[:1]))
    out = np.zeros_like(joints)
    out[ends] = turn
    first = np.searchsorted(ends, np.arange(len(joints)))  # the end row of each row's block
    return out[ends[np.minimum(first, len(ends) - 1)]]


def _first_of_block(motions: PartMotions, rows: np.ndarray) -> np.ndarray:
    """Mask of ``rows`` keeping one row per block (the first)."""
    if motions.block is None or not rows.size:
        return np.ones(rows.size, bool)
    blocks = motions.block[rows]
    return np.concatenate([[True], blocks[1:] != blocks[:-1]])


def machine_xyz(motions: PartMotions, machine: Machine) -> np.ndarray:
    """Machine X Y Z ``(N,3)`` mm of every row (the program's own without tool-centre-point
    control; from the part-frame tip and the rotary positions with it)."""
    chain = Chain(machine)
    xyz = np.array(motions.xyz, dtype=float)
    tcp = motions.tcp
    if tcp is not None and tcp.any():
        j = np.nan_to_num(motions.joints[tcp])
        xyz[tcp] = chain.inverse_position(motions.tip[tcp], j, tcp=False)
    return xyz


def machine_checks(moves: GcodeMoves, motions: PartMotions, machine: Machine) -> list[dict]:
    """Findings ``{check, line, count, message}`` of the program on ``machine`` (see module)."""
    out: list[dict] = []
    lines = motions.line
    known = motions.known
    chain = Chain(machine)
    xyz = machine_xyz(motions, machine)
    limits = np.array([machine.travel.x, machine.travel.y, machine.travel.z])
    with np.errstate(invalid="ignore"):
        for k, letter in enumerate("XYZ"):
            col = xyz[:, k]
            bad = np.flatnonzero(known & ((col < limits[k, 0] - 1e-6) | (col > limits[k, 1]
                                                                          + 1e-6)))
            if bad.size:
                worst = bad[np.argmax(np.abs(col[bad] - limits[k].mean()))]
                out.append(_finding(
                    "travel", bad, lines,
                    f"{letter} reaches {col[worst]:.4f} mm (machine coordinates), expected "
                    f"within [{limits[k, 0]:g}, {limits[k, 1]:g}] of machine '{machine.name}'",
                    unit="points"))
    joints = motions.joints if motions.joints is not None else np.zeros((len(lines), 0))
    piece = np.abs(np.diff(joints, axis=0, prepend=joints[:1]))  # per row (piece of a block)
    step = _per_block(motions, joints)  # per block, on each of its rows
    minutes = motions.minutes if motions.minutes is not None else np.full(len(lines), np.nan)
    for i, axis in enumerate(machine.rotary_axes):
        col = joints[:, i]
        span = axis.word_range()
        if span is not None:
            bad = np.flatnonzero(np.isfinite(col) & ((col < span[0] - 1e-6)
                                                     | (col > span[1] + 1e-6)))
            if bad.size:
                out.append(_finding(
                    "rotary-limit", bad, lines,
                    f"{axis.name} at {col[bad[0]]:.4f} deg, expected within "
                    f"[{span[0]:g}, {span[1]:g}] ({axis.wrap})", unit="points"))
        wide = np.flatnonzero(~motions.rapid & (step[:, i] > axis.max_turn_in_cut))
        if span is None:
            wide = np.union1d(wide, np.flatnonzero(step[:, i] >= 180.0))
        wide = wide[_first_of_block(motions, wide)]
        if wide.size:
            out.append(_finding(
                "wrap", wide, lines,
                f"{axis.name} turns {step[wide[0], i]:.3f} deg in one block "
                f"({'rollover' if span is None else 'range ' + str(span)}; more than "
                f"max_turn_in_cut {axis.max_turn_in_cut:g} in a cut, or half a turn)"))
        with np.errstate(invalid="ignore", divide="ignore"):
            rate = piece[:, i] / minutes
        fast = np.flatnonzero(np.isfinite(rate) & (rate > axis.max_feed * (1 + 1e-3)))
        if fast.size:
            worst = fast[np.argmax(rate[fast])]
            fast = fast[_first_of_block(motions, fast)]
            out.append(_finding(
                "rotary-feed", fast, lines,
                f"{axis.name} turns at {rate[worst]:.1f} deg/min (line {int(lines[worst])} "
                f"worst), above the machine's {axis.max_feed:g} deg/min"))
    with np.errstate(invalid="ignore", divide="ignore"):
        lin = np.linalg.norm(np.diff(xyz, axis=0, prepend=xyz[:1]), axis=1) / minutes
    fast = np.flatnonzero(np.isfinite(lin) & (lin > machine.feeds.max_linear * (1 + 1e-3)))
    if fast.size:
        worst = fast[np.argmax(lin[fast])]
        fast = fast[_first_of_block(motions, fast)]
        mode = int(motions.feed_mode[worst]) if motions.feed_mode is not None else 94
        hint = (" (G95: F is per revolution and multiplies the spindle speed: a per-minute F "
                "under G95?)" if mode == 95 else "")
        out.append(_finding(
            "feed", fast, lines,
            f"the linear axes move at {lin[worst]:.1f} mm/min (line {int(lines[worst])} worst, "
            f"G{mode}), above the machine's {machine.feeds.max_linear:g} mm/min{hint}"))
    if len(chain.ops) == 2 and len(lines):
        sol = chain.solve(np.nan_to_num(motions.axis, nan=0.0) + np.where(
            np.isfinite(motions.axis).all(axis=1, keepdims=True), 0.0, [0.0, 0.0, 1.0]))
        free = chain.ops[0][0]
        near = sol.pole < POLE_DEG
        near[1:] |= near[:-1]
        if motions.block is not None:  # anywhere along the block
            near = np.bincount(motions.block, weights=near.astype(float))[motions.block] > 0
        flip = np.flatnonzero(known & near & (step[:, free] > FLIP_DEG))
        flip = flip[_first_of_block(motions, flip)]
        if flip.size:
            out.append(_finding(
                "singular", flip, lines,
                f"{machine.rotary_axes[free].name} swings {step[flip[0], free]:.3f} deg in one "
                f"block with the tool axis within {POLE_DEG:g} deg of the "
                f"{machine.rotary_axes[free].name} axis (singular passage: the tip may leave "
                "the path while the axis swings)"))
    return out
