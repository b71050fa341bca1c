"""Posting: from a tool path (part frame: tips and tool axes) to a G-code program for a machine.

Data flow: `PostMoves` (plain arrays, part frame, mm, degrees) -> rotary words from the tool
axes (the chain's inverse kinematics: for 5-axis machines the solution chosen for continuity and
limits, pole passages reported) -> program X Y Z (machine coordinates, or work-frame tips with
tool-centre-point control) -> blocks split where a rotary axis turns MAX_STEP or more -> words
per wrap mode, with retract / rotate / re-enter where a cut crosses the end of a word range or
turns too far, approach after each tool change -> feed words (G94 rule of the dialect or G93
inverse time) -> travel-limit check in machine coordinates -> text (`checker.postproc.writer`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from checker.config import default_config
from checker.errors import PathcheckError, raise_at_first
from checker.postproc.dialects import get_dialect
from checker.postproc.header import NOT_CHECKED, header_lines
from checker.postproc.kinematics import (
    PATH_SUBSTEPS,
    Chain,
    Choice,
    axis_from_rotation,
    rotation_from_axis,
)
from checker.postproc.machine import Machine, load_machine
from checker.postproc.wrap import MAX_STEP, range_branches, rollover_words
from checker.postproc.writer import Rows, format_program, write_program
from checker.units import mm_per_unit


@dataclass(frozen=True)
class PostMoves:
    """What the post needs per move, all in the part frame: ``tip (N,3)`` mm, unit ``axis (N,3)``
    (tip -> spindle), ``b_deg (N,)`` the part rotation about +Y in degrees that gives the axis
    (docs/MATH.md §1 b, before ``b_direction``; NaN where the axis is not of that form), ``rapid
    (N,)`` bool, ``feed (N,)`` mm/min (nan for rapids), ``spindle
    (N,)`` rpm in effect (+ CW/M3, - CCW/M4, 0 stopped, nan unknown), ``coolant (N,)`` in effect
    (0 off, 7 mist, 8 flood, -1 unknown), ``tool (N,)`` in effect (0 unknown), ``comment`` one
    text per move ('' none; flagged points), ``line (N,)`` source line of each move, ``source``
    the CL file (named in errors), ``units`` the job's units ('mm' or 'inch'): the program is
    written in them (None: the machine's), ``stop (N,)`` an optional stop (M01) after the move's
    comment (None: none)."""

    tip: np.ndarray
    axis: np.ndarray
    b_deg: np.ndarray
    rapid: np.ndarray
    feed: np.ndarray
    spindle: np.ndarray
    coolant: np.ndarray
    tool: np.ndarray
    comment: tuple[str, ...]
    line: np.ndarray
    source: str | None = None
    units: str | None = None
    stop: np.ndarray | None = None

    @classmethod
    def build(
        cls,
        tip: np.ndarray,
        b_deg: np.ndarray | float | None = None,
        *,
        axis: np.ndarray | None = None,
        rapid: np.ndarray | None = None,
        feed: np.ndarray | float | None = None,
        spindle: np.ndarray | float | None = None,
        coolant: np.ndarray | int | None = None,
        tool: np.ndarray | int | None = None,
        comment: list[str] | tuple[str, ...] | None = None,
        line: np.ndarray | None = None,
        source: str | None = None,
        units: str | None = None,
        stop: np.ndarray | None = None,
    ) -> PostMoves:
        """Moves from tips ``(N,3)`` and either B ``(N,)`` degrees (the axis follows from B) or
        part-frame tool ``axis (N,3)`` (any direction: 5-axis); scalars broadcast, missing fields
        take their 'unknown' value."""
        tip = np.asarray(tip, dtype=float).reshape(-1, 3)
        n = len(tip)
        if axis is not None:
            ax = np.broadcast_to(np.asarray(axis, dtype=float), (n, 3)).copy()
            ax /= np.linalg.norm(ax, axis=1, keepdims=True)
            b = np.full(n, np.nan)
        else:
            b = np.broadcast_to(np.asarray(0.0 if b_deg is None else b_deg, float), (n,)).copy()
            ax = axis_from_rotation(np.radians(b))

        def full(value, default, dtype):
            return np.broadcast_to(
                np.asarray(default if value is None else value, dtype=dtype), (n,)
            ).copy()

        return cls(
            tip=tip,
            axis=ax,
            b_deg=b,
            rapid=full(rapid, False, bool),
            feed=full(feed, np.nan, float),
            spindle=full(spindle, np.nan, float),
            coolant=full(coolant, -1, int),
            tool=full(tool, 0, int),
            comment=tuple(comment) if comment is not None else ("",) * n,
            line=full(line, 0, int) if line is not None else np.arange(1, n + 1),
            source=source,
            units=units,
            stop=None if stop is None else full(stop, False, bool),
        )

    def __len__(self) -> int:
        return len(self.tip)


def moves_from_toolpath(
    toolpath,
    b_deg=None,
    cc=None,
    normals=None,
    cutter=None,
    *,
    arc_chord_tol: float | None = None,
    comments: list[str] | None = None,
    tip=None,
    four_axis: bool = True,
    stops: np.ndarray | None = None,
    axes=None,
) -> PostMoves:
    """PostMoves from a `checker.toolpath.ToolPath`: the rows of
    ``toolpath.motion_arrays(arc_chord_tol)`` (arcs cut into chords of that sagitta, mm; None:
    the config's ``check.arc_chord_tolerance``, the rows the checker sees) with their rapid
    flag, feed, spindle, coolant (where the arrays carry it), line and the tool number of their
    operation. With ``b_deg (N,)`` (the chosen B, degrees) the axis becomes ``(-sin b, 0, cos
    b)`` (rows with nan keep the CL axis: a 5-axis machine's words follow from it), else B
    follows from the CL axis; with ``cc (N,3)``, ``normals (N,3)`` (part frame,
    out of the material) and ``cutter`` the tip is recomputed from the contact by
    ``cutter.tip_from_contact(cc, n, axis)`` at the new axis. ``comments`` (one per row, ''
    none) are written before the blocks (flags), ``stops (N,)`` bool an optional stop (M01)
    after them. ``tip (N,3)`` (part frame, mm) replaces the CL tips outright (the checker's
    recomputed tips at the chosen B); ``axes (N,3)`` the CL axes (the checker's re-oriented
    multi-axis rows; a row with a B takes the B's axis). ``four_axis=False`` keeps the CL axes
    as they are (5-axis jobs; the machine's inverse kinematics finds the words)."""
    if arc_chord_tol is None:
        arc_chord_tol = default_config().check.arc_chord_tolerance
    arrays = toolpath.motion_arrays(arc_chord_tol)
    lines = np.asarray(arrays.line)
    b = None
    axis = np.asarray(arrays.axis if axes is None else axes, dtype=float)
    if b_deg is not None:  # rows without a B (nan: a multi-axis operation) keep their axis
        b = np.asarray(b_deg, dtype=float)
        given = np.isfinite(b)
        axis = np.where(given[:, None], axis_from_rotation(np.radians(np.nan_to_num(b))), axis)
        b = b if given.all() else None
    elif four_axis:
        b = rotation_from_axis(
            axis,
            j_tolerance=default_config().four_axis.axis_j_tolerance,
            lines=lines,
            path=str(toolpath.path),
        )
        axis = axis_from_rotation(np.radians(b))
    tip = np.asarray(arrays.tip if tip is None else tip, dtype=float)
    if cc is not None and normals is not None and cutter is not None:
        tip = np.asarray(
            cutter.tip_from_contact(np.asarray(cc, float), np.asarray(normals, float), axis)
        )
    numbers = np.array([op.tool_number or 0 for op in toolpath.operations] or [0], dtype=int)
    return PostMoves.build(
        tip,
        b,
        axis=None if b is not None else axis,
        rapid=arrays.rapid,
        feed=arrays.feed,
        spindle=arrays.spindle,
        coolant=getattr(arrays, "coolant", None),  # where the CL reader records COOLNT
        tool=numbers[np.asarray(arrays.op, dtype=int)],
        comment=comments,
        line=lines,
        source=str(toolpath.path),
        units=toolpath.units,
        stop=stops,
    )


def machine_for_toolpath(toolpath, name: str | Path | Machine | None = None) -> Machine:
    """The machine to post ``toolpath`` for: ``name`` (a Machine, a machine name or .toml file)
    when given, else the CL file's ``PPRINT/MACHINE NAME``, else the default machine
    (fanuc-hmc)."""
    if isinstance(name, Machine):
        return name
    return load_machine(toolpath.machine_name() if name is None else name)


@dataclass
class PostedProgram:
    """The program text and, per written row, its program line (1-based, -1 when the block was
    empty and omitted), its source move (-1 inserted) and whether it ends that source move;
    ``choice`` the rotary solution the post chose per source move (sheets, switches, singular
    rows) and ``notes`` one line per kinematic event (written as comments too)."""

    text: str
    rows: Rows = field(repr=False)
    choice: Choice | None = field(default=None, repr=False)
    notes: list[str] = field(default_factory=list)


def _validate(moves: PostMoves, machine: Machine) -> None:
    n = len(moves)
    for name in ("axis", "b_deg", "rapid", "feed", "spindle", "coolant", "tool", "line",
                 "comment", "stop"):
        column = getattr(moves, name)
        if column is not None and len(column) != n:
            raise PathcheckError(
                f"PostMoves.{name} has {len(column)} rows, expected {n}", code="post"
            )
    if n == 0:
        raise PathcheckError("nothing to post: the tool path has no moves", code="post")
    where = {"path": moves.source, "code": "post"}
    finite = np.isfinite(moves.tip).all(axis=1) & np.isfinite(moves.axis).all(axis=1)
    raise_at_first(~finite, moves.line, lambda k: "move has a non-finite tip or tool axis",
                   **where)
    mismatch = np.isfinite(moves.b_deg) & (
        np.linalg.norm(moves.axis - axis_from_rotation(np.radians(np.nan_to_num(moves.b_deg))),
                       axis=1) > 1e-6
    )
    raise_at_first(mismatch, moves.line, lambda k: (
        f"tool axis {tuple(np.round(moves.axis[k], 6))} does not match "
        f"B = {moves.b_deg[k]:.4f} deg: expected (-sin B, 0, cos B)"), **where)
    raise_at_first(~moves.rapid & ~(moves.feed > 0), moves.line,
                   lambda k: "feed move without a feed rate: expected a FEDRAT > 0 before it",
                   **where)


def rotary_words(moves: PostMoves, machine: Machine) -> tuple[np.ndarray, Choice]:
    """Continuous rotary positions ``(N,k)`` degrees for the moves' tool axes (the chain's
    inverse kinematics and solution choice). For a one-axis machine with B given, the first word
    is the given B (as the 4-axis planner chose it), continued without jumps."""
    chain = Chain(machine)
    start = None
    if chain.k == 1 and np.isfinite(moves.b_deg[0]):
        sign = machine.kinematics.b_direction
        start = np.array([sign * float(moves.b_deg[0])])
        if abs(chain.direction[0] @ chain.rot[:, 1]) < 0.5:
            start = None  # the table does not turn about part Y: no B to follow
    tol = default_config().four_axis.axis_j_tolerance
    joints, choice, _ = chain.words_for_axes(
        moves.axis, start=start, lines=moves.line, path=moves.source,
        tolerance=float(np.degrees(np.arcsin(min(tol, 1.0)))) + 1e-9,
    )
    return joints, choice


def _pieces(moves: PostMoves, machine: Machine, w: np.ndarray) -> dict[str, np.ndarray]:
    """Source moves as program rows, split so no block turns any axis MAX_STEP degrees or
    more; ``w (N,k)`` continuous rotary positions."""
    chain = Chain(machine)
    xyz = chain.inverse_position(moves.tip, w, machine.tcp.enabled)
    step = np.abs(np.diff(w, axis=0, prepend=w[:1])) if w.shape[1] else np.zeros((len(w), 1))
    count = np.maximum(1, np.ceil(step.max(axis=1) / MAX_STEP - 1e-12)).astype(int)
    src = np.repeat(np.arange(len(moves)), count)
    j = np.arange(src.size) - np.repeat(np.cumsum(count) - count, count) + 1
    t = (j / count[src])[:, None]
    prev = np.maximum(src - 1, 0)
    return {
        "xyz": xyz[prev] + t * (xyz[src] - xyz[prev]),
        "wc": w[prev] + t * (w[src] - w[prev]),
        "src": src,
        "end": j == count[src],
        "feed_move": ~moves.rapid[src],
    }


def _starts(moves: PostMoves) -> np.ndarray:
    """Source moves that begin with an approach: the first move and every tool change."""
    change = np.flatnonzero(np.diff(moves.tool) != 0) + 1
    return np.union1d([0], change)


def _big_turns(moves: PostMoves, machine: Machine, w: np.ndarray) -> np.ndarray:
    """Cuts (not starts) that turn a rotary axis more than its ``max_turn_in_cut``: made as
    retract, rotate, re-enter."""
    if not machine.rotary_axes:
        return np.zeros(0, int)
    limit = np.array([a.max_turn_in_cut for a in machine.rotary_axes])
    turn = np.abs(np.diff(w, axis=0, prepend=w[:1]))
    big = np.any(turn > limit, axis=1) & ~moves.rapid
    big[_starts(moves)] = False
    return np.flatnonzero(big)


def _row(xyz, word, turn, motion, src, *, end=False, g43=False, force=False) -> dict:
    k = np.asarray(word, float).size
    return {
        "xyz": np.asarray(xyz, float).reshape(1, 3),
        "word": np.asarray(word, float).reshape(1, k),
        "turn": np.asarray(turn, float).reshape(1, k),
        "motion": np.array([motion], int),
        "src": np.array([src], int),
        "end": np.array([end]),
        "g43": np.array([g43]),
        "force": np.array([force]),
    }


def _assemble(moves: PostMoves, machine: Machine, w: np.ndarray) -> dict[str, np.ndarray]:
    """All program rows in program order: the split source moves plus approach and
    retract-rotate-re-enter rows. ``turn (M,k)`` is the rotary position the control reaches
    (degrees, continuous), used for block times."""
    p = _pieces(moves, machine, w)
    m = p["src"].size
    k = len(machine.rotary_axes)
    word = np.zeros((m, k))
    branch = np.zeros((m, k), dtype=int)
    for i, axis in enumerate(machine.rotary_axes):
        span = axis.word_range()
        if span is None:
            word[:, i] = rollover_words(p["wc"][:, i], axis.wrap, machine.format.rotary_decimals)
        else:
            branch[:, i] = range_branches(p["wc"][:, i], *span, lines=moves.line[p["src"]],
                                          path=moves.source)
            word[:, i] = p["wc"][:, i] + 360.0 * branch[:, i]
    rollover = [a.word_range() is None for a in machine.rotary_axes]
    turn = np.where(rollover, p["wc"], word) if k else word
    rows = {
        "xyz": p["xyz"],
        "word": word,
        "turn": turn,
        "motion": p["feed_move"].astype(int),
        "src": p["src"],
        "end": p["end"],
        "g43": np.zeros(m, bool),
        "force": np.zeros(m, bool),
    }
    starts = _starts(moves)
    whole = np.union1d(starts, _big_turns(moves, machine, w))  # moves kept as their end row
    first = np.searchsorted(p["src"], whole, "left")
    last_piece = np.searchsorted(p["src"], whole, "right") - 1
    skip = np.zeros(m, bool)
    for a, b in zip(first, last_piece, strict=True):
        skip[a:b] = True
    approach = set(last_piece[np.isin(whole, starts)].tolist())
    reenter = {int(i): int(f) for i, f in zip(last_piece, first, strict=True) if i not in approach}
    changed = np.any(np.diff(branch, axis=0) != 0, axis=1) if k else np.zeros(max(m - 1, 0), bool)
    jumps = {int(i) for i in np.flatnonzero(changed) + 1 if not skip[i]}
    jumps -= approach | set(reenter)
    clearance = machine.program.reentry_clearance
    safe = machine.program.safe_z
    chunks: list[dict[str, np.ndarray]] = []
    last = 0
    nan_word = np.full(k, np.nan)
    for i in sorted(approach | jumps | set(reenter)):
        keep = ~skip[last:i]
        chunks.append({key: val[last:i][keep] for key, val in rows.items()})
        x, y, z = rows["xyz"][i]
        src = int(rows["src"][i])
        here = {key: val[i : i + 1] for key, val in rows.items()}
        if i in approach:
            tool = int(moves.tool[src]) > 0
            if not tool:  # no tool change retracted the spindle: go to the safe plane first
                chunks.append(_row([np.nan, np.nan, safe], nan_word, turn[i], 0, src, force=True))
            chunks.append(_row([x, y, np.nan], word[i], turn[i], 0, src, force=True))
            if rows["motion"][i] == 0:
                here = {**here, "g43": np.array([tool]), "force": np.array([True])}
            else:
                chunks.append(
                    _row([x, y, z + clearance], word[i], turn[i], 0, src, g43=tool, force=True)
                )
        elif rows["motion"][i] == 0 or i in reenter:
            # a rapid across the end of a word range, or a cut turning too far: retract from
            # the previous point, turn, come back over the end point (feed in if a cut)
            j = reenter.get(i, i) - 1
            xp, yp, zp = rows["xyz"][j]
            up = max(safe, zp)
            chunks += [
                _row([xp, yp, up], word[j], turn[j], 0, src),
                _row([xp, yp, up], word[i], turn[i], 0, src),
                _row([x, y, up], word[i], turn[i], 0, src),
            ]
            if rows["motion"][i] == 1:
                chunks.append(_row([x, y, z + clearance], word[i], turn[i], 0, src))
        else:  # a cut across the end of a word range: split there, retract, turn back, re-enter
            chunks += _crossing(rows, branch, i, machine, moves)
        chunks.append(here)
        last = i + 1
    keep = ~skip[last:]
    chunks.append({key: val[last:][keep] for key, val in rows.items()})
    return {key: np.concatenate([c[key] for c in chunks]) for key in rows}


def _on_increments(rows: dict[str, np.ndarray], machine: Machine) -> dict[str, np.ndarray]:
    """The rows at the positions the control runs: program X Y Z (mm, rounded in the program's
    units) and the rotary words and positions rounded to the machine's increments, so that the
    feed words and the checks are those of the program as written."""
    fmt = machine.format
    scale = mm_per_unit(machine.units)
    linear, rotary = fmt.linear_decimals(machine.units), fmt.rotary_decimals
    return {**rows, "xyz": np.round(rows["xyz"] / scale, linear) * scale,
            "word": np.round(rows["word"], rotary), "turn": np.round(rows["turn"], rotary)}


def _crossing(rows, branch, i: int, machine: Machine, moves: PostMoves) -> list[dict]:
    """Rows that replace the first part of cut ``i`` where an axis's word must change branch:
    cut to the range end, retract to safe Z, turn a full turn back, rapid down, feed in."""
    axis_i = int(np.flatnonzero(branch[i] != branch[i - 1])[0])
    lo, hi = machine.rotary_axes[axis_i].word_range()
    src = int(rows["src"][i])
    w0 = rows["word"][i - 1]
    # the change of this block as the path turns (|delta| < MAX_STEP), on the old branch
    delta = (rows["word"][i] - w0 + 180.0) % 360.0 - 180.0
    d = delta[axis_i]
    bound = hi if d > 0 else lo
    t = (bound - w0[axis_i]) / d
    xyz = rows["xyz"][i - 1] + t * (rows["xyz"][i] - rows["xyz"][i - 1])
    at_bound = w0 + t * delta
    at_bound[axis_i] = bound
    new_word = at_bound.copy()
    new_word[axis_i] = bound - 360.0 if d > 0 else bound + 360.0
    name = machine.rotary_axes[axis_i].name
    if not lo - 1e-9 <= new_word[axis_i] <= hi + 1e-9:
        raise PathcheckError(
            f"{name} must pass {bound:g} deg during a cut, and the {name} word range "
            f"[{lo:g}, {hi:g}] is less than a full turn: no retract-rotate-re-enter can "
            "continue the cut",
            path=moves.source,
            line=int(moves.line[src]),
            code="travel",
        )
    turn_b = rows["turn"][i - 1] + t * (rows["turn"][i] - rows["turn"][i - 1])
    turn_n = turn_b.copy()
    turn_n[axis_i] = new_word[axis_i]
    turn_b[axis_i] = bound
    up = max(machine.program.safe_z, xyz[2])
    out = []
    if t > 1e-9:
        out.append(_row(xyz, at_bound, turn_b, 1, src))
    return out + [
        _row([xyz[0], xyz[1], up], at_bound, turn_b, 0, src),
        _row([xyz[0], xyz[1], up], new_word, turn_n, 0, src),
        _row([xyz[0], xyz[1], xyz[2] + machine.program.reentry_clearance], new_word, turn_n, 0,
             src),
        _row(xyz, new_word, turn_n, 1, src),
    ]


def _feed_words(rows: dict[str, np.ndarray], moves: PostMoves, machine: Machine) -> np.ndarray:
    """F word ``(M,)`` of each feed row (nan elsewhere). Block time ``t = max(L / feed, |dW| /
    rotary max of each axis, |dXYZ| / linear max)`` minutes, L the tip path length relative to
    the part (straight with tool-centre-point control); G93: ``F = 1 / t``; G94 (the dialect's
    rule): ``F = D / t`` with D the distance the control applies F to, so the control's block
    time is ``t`` (and t >= D / linear max, so the control never clamps F)."""
    chain = Chain(machine)
    tcp = machine.tcp.enabled
    out = np.full(rows["motion"].size, np.nan)
    i = np.flatnonzero(rows["motion"] == 1)
    prev = i - 1
    xyz0, xyz1 = rows["xyz"][prev], rows["xyz"][i]
    turn0, turn1 = rows["turn"][prev], rows["turn"][i]
    length = chain.tip_path_length(xyz0, xyz1, turn0, turn1, tcp)
    dxyz = xyz1 - xyz0
    dturn = turn1 - turn0
    scale = 1.0 / mm_per_unit(machine.units)
    max_rot = np.array([a.max_feed for a in machine.rotary_axes]).reshape(1, -1)
    limits = [
        length / moves.feed[rows["src"][i]],
        (np.abs(dturn) / max_rot).max(axis=1, initial=0.0),
        _linear_reach(chain, xyz0, xyz1, turn0, turn1, tcp) / machine.feeds.max_linear,
    ]
    g93 = machine.feeds.rotary_mode == "g93"
    distance = get_dialect(machine.dialect).feed_distance(dxyz * scale, dturn, tcp)
    if not g93:
        limits.append(distance / (machine.feeds.max_linear * scale))
    t = np.maximum.reduce(limits)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = 1.0 / t if g93 else distance / t
    out[i] = np.where(t > 0, f, np.nan)
    return out


def _linear_reach(chain: Chain, xyz0, xyz1, turn0, turn1, tcp: bool) -> np.ndarray:
    """``(M,)`` the distance the linear axes would cover at their fastest: ``|dXYZ|`` without
    tool-centre-point control (they run straight and uniformly); with it the machine X Y Z
    follow a curve as the tip runs straight and the rotary axes turn, so the fastest of
    PATH_SUBSTEPS pieces times their number (a block time ``t >= that / max_linear`` keeps every
    piece within the machine's linear maximum)."""
    if not tcp:
        return np.linalg.norm(xyz1 - xyz0, axis=1)
    steps = PATH_SUBSTEPS
    fastest = np.zeros(len(xyz0))
    prev = chain.inverse_position(chain.to_part(xyz0), turn0, tcp=False)
    for s in range(1, steps + 1):  # a loop over sub-steps, each over all blocks
        t = s / steps
        here = chain.inverse_position(chain.to_part(xyz0 + t * (xyz1 - xyz0)),
                                      turn0 + t * (turn1 - turn0), tcp=False)
        fastest = np.maximum(fastest, np.linalg.norm(here - prev, axis=1))
        prev = here
    return fastest * steps


def _spindle_block(rpm: float, code) -> str:
    if rpm == 0:
        return code("M", 5)
    return f"S{abs(rpm):g} {code('M', 3 if rpm > 0 else 4)}"


def _pre_blocks(
    rows: dict[str, np.ndarray], moves: PostMoves, machine: Machine, w: np.ndarray,
    choice: Choice,
) -> dict[int, list[str]]:
    """Blocks before the first row of a source move: its comment (flag), kinematic notes (pole
    passages, solution switches), a note where a cut turns too far for cutting, tool change (with
    tool-centre-point control off before and on after it), spindle, coolant, each written only
    where it changes (and again after a tool change)."""
    dialect = get_dialect(machine.dialect)
    code = dialect.format_code
    src_ids, first_row = np.unique(rows["src"], return_index=True)
    n = len(moves)
    starts = np.zeros(n, bool)
    starts[_starts(moves)] = True
    toolchange = starts & (moves.tool > 0)
    spindle_change = np.isfinite(moves.spindle) & (
        toolchange | np.concatenate([[True], moves.spindle[1:] != moves.spindle[:-1]])
    )
    coolant_change = (moves.coolant >= 0) & (
        toolchange | np.concatenate([[True], moves.coolant[1:] != moves.coolant[:-1]])
    )
    has_comment = np.array([bool(c.strip()) for c in moves.comment])
    stop = np.zeros(n, bool) if moves.stop is None else moves.stop
    big = np.zeros(n, bool)
    big[_big_turns(moves, machine, w)] = True
    notes: dict[int, list[str]] = {}
    for r, text in choice.notes:
        notes.setdefault(int(r), []).append(text)
    noted = np.zeros(n, bool)
    noted[list(notes)] = True
    tcp = machine.tcp.enabled
    separate_tcp = tcp and "{tool" not in dialect.tcp_on_block
    pre: dict[int, list[str]] = {}
    events = np.flatnonzero(has_comment | stop | big | toolchange | spindle_change | coolant_change
                            | noted | starts)
    row_of = dict(zip(src_ids.tolist(), first_row.tolist(), strict=True))
    names = [a.name for a in machine.rotary_axes]
    for k in events.tolist():
        blocks = []
        if has_comment[k]:
            blocks.append(dialect.comment(moves.comment[k]))
        if stop[k]:
            blocks.append(code("M", 1))
        for text in notes.get(k, ()):
            blocks.append(dialect.comment(f"PATHCHECK KINEMATICS {text}"))
        if big[k]:
            d = (w[k] - w[k - 1] + 180.0) % 360.0 - 180.0
            turned = ", ".join(f"{a} {v:+.3f}" for a, v in zip(names, d, strict=True)
                               if abs(v) > 1e-9)
            blocks.append(dialect.comment(
                f"{turned} deg in one cut (line {int(moves.line[k])}): retract, rotate, re-enter"
            ))
        if toolchange[k]:
            if tcp and k > 0:
                blocks.append(dialect.tcp_off_block)
            lines = machine.program.tool_change
            lines = dialect.tool_change if lines is None else lines
            blocks += [t.format(tool=int(moves.tool[k])) for t in lines]
        if spindle_change[k]:
            blocks.append(_spindle_block(float(moves.spindle[k]), code))
        if coolant_change[k]:
            blocks.append(code("M", {0: 9, 7: 7, 8: 8}.get(int(moves.coolant[k]), 8)))
        if starts[k] and separate_tcp:
            blocks.append(dialect.tcp_on_block.format(tool=int(moves.tool[k])))
        if blocks:
            pre[row_of[k]] = blocks
    return pre


def _machine_xyz(rows: Rows, machine: Machine) -> np.ndarray:
    """Machine X Y Z of every row (the program's own with no tool-centre-point control)."""
    if not machine.tcp.enabled:
        return rows.xyz
    chain = Chain(machine)
    tip = chain.to_part(rows.xyz)
    return chain.inverse_position(tip, np.nan_to_num(rows.turn), tcp=False)


def _check_travel(rows: Rows, text: str, machine: Machine, moves: PostMoves) -> None:
    """A travel-limit violation (machine coordinates) is an error naming the block, its program
    line and source line."""
    limits = np.array([machine.travel.x, machine.travel.y, machine.travel.z])
    xyz = _machine_xyz(rows, machine)
    with np.errstate(invalid="ignore"):
        bad = (xyz < limits[:, 0] - 1e-9) | (xyz > limits[:, 1] + 1e-9)
    bad &= (rows.line > 0)[:, None]
    if not bad.any():
        return
    i, axis = (int(v) for v in np.argwhere(bad)[0])
    program_line = int(rows.line[i])
    block = text.splitlines()[program_line - 1]
    lo, hi = limits[axis]
    raise PathcheckError(
        f"travel limit: block '{block}' (program line {program_line}) moves {'XYZ'[axis]} to "
        f"{xyz[i, axis]:.4f} mm, expected within [{lo:g}, {hi:g}] of machine '{machine.name}'",
        path=moves.source,
        line=int(moves.line[rows.src[i]]),
        code="travel",
    )


def tool_lines(toolpath, cutters: dict[int, object] | None = None) -> list[str]:
    """One header line per tool of ``toolpath`` in program order, e.g. ``3 CUTTER/12,6,...``:
    every operation's cutter (``cutters`` by operation index where given, else the CL's), each
    tool number and cutter once."""
    out: list[str] = []
    for o, op in enumerate(toolpath.operations):
        cutter = (cutters or {}).get(o, op.cutter)
        text = f"{op.tool_number or 0} " + ("-" if cutter is None else cutter.to_apt())
        if text not in out:
            out.append(text)
    return out


def post(moves: PostMoves, machine: Machine, *, program_name: str = "PATHCHECK",
         tools: list[str] | None = None, verdict: str = NOT_CHECKED) -> PostedProgram:
    """Post ``moves`` for ``machine`` in the job's units: the program text, the row table and
    the rotary solution chosen (see PostedProgram). The header names ``tools`` (default: the
    moves' tool numbers) and the ``verdict`` (`checker.postproc.header.verdict_text`)."""
    _validate(moves, machine)
    if moves.units is not None and moves.units != machine.units:
        machine = machine.model_copy(update={"units": moves.units})
    w, choice = rotary_words(moves, machine)
    assembled = _on_increments(_assemble(moves, machine, w), machine)
    rows = Rows(
        xyz=assembled["xyz"],
        word=assembled["word"],
        turn=assembled["turn"],
        motion=assembled["motion"],
        fword=_feed_words(assembled, moves, machine),
        g43=assembled["g43"],
        force=assembled["force"],
        src=assembled["src"],
        end=assembled["end"],
        tool=moves.tool[assembled["src"]],
    )
    pre = _pre_blocks(assembled, moves, machine, w, choice)
    if tools is None:
        tools = [str(t) for t in dict.fromkeys(moves.tool.tolist())]
    header = header_lines(source=moves.source, machine=machine.name, tools=tools, verdict=verdict)
    text = format_program(rows, machine, get_dialect(machine.dialect), pre, program_name, header)
    _check_travel(rows, text, machine, moves)
    return PostedProgram(text=text, rows=rows, choice=choice,
                         notes=[t for _, t in choice.notes])


def post_program(moves: PostMoves, machine: Machine, *, program_name: str = "PATHCHECK",
                 tools: list[str] | None = None, verdict: str = NOT_CHECKED) -> str:
    """G-code text for ``moves`` on ``machine`` (see `post`)."""
    return post(moves, machine, program_name=program_name, tools=tools, verdict=verdict).text


def post_toolpath(
    toolpath,
    out: str | Path,
    *,
    machine: str | Machine | None = None,
    b_deg=None,
    cc=None,
    normals=None,
    cutter=None,
    comments: list[str] | None = None,
    stops: np.ndarray | None = None,
    arc_chord_tol: float | None = None,
    tip=None,
    cutters: dict[int, object] | None = None,
    verdict: str = NOT_CHECKED,
    axes=None,
) -> Path:
    """The job's corrected G-code in one call (what `pathcheck JOB.apt -o JOB.nc [--machine
    NAME]` needs): the machine by `machine_for_toolpath`, the moves by `moves_from_toolpath`
    (same arguments), posted with a header naming every tool (`tool_lines`, ``cutters`` the
    real cutter per operation index) and the ``verdict``, and written atomically to ``out``;
    returns the path written."""
    mach = machine_for_toolpath(toolpath, machine)
    moves = moves_from_toolpath(
        toolpath, b_deg, cc, normals, cutter, arc_chord_tol=arc_chord_tol, comments=comments,
        tip=tip, four_axis=b_deg is not None, stops=stops, axes=axes,
    )
    name = Path(str(toolpath.path)).stem.upper() or "PATHCHECK"
    text = post_program(moves, mach, program_name=name, tools=tool_lines(toolpath, cutters),
                        verdict=verdict)
    return write_program(text, out)
