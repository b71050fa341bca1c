"""Posting: from a tool path (part frame) and the chosen B at each move to a G-code program.

Data flow: `PostMoves` (plain arrays, part frame, mm, degrees) -> machine X Y Z and continuous B
(kinematics) -> blocks split where B turns MAX_STEP or more -> B words per wrap mode, with
retract / rotate / re-enter where a cut crosses the end of the B word range, approach after each
tool change -> feed words (G94 rotary rule or G93 inverse time) -> travel-limit check -> text
(`postproc.writer`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from checker.config import default_config
from checker.errors import PathcheckError
from postproc.dialects import get_dialect
from postproc.kinematics import (
    axis_from_rotation,
    part_to_machine,
    rotation_from_axis,
    tip_path_length,
)
from postproc.machine import Machine, load_machine
from postproc.wrap import pieces_per_move, range_branches, rollover_words
from postproc.writer import MM_PER_INCH, Rows, comment, format_program, write_program


@dataclass(frozen=True)
class PostMoves:
    """What the post needs per move, all in the part frame: ``tip (N,3)`` mm, unit ``axis (N,3)``
    (tip -> spindle), ``b_deg (N,)`` the part rotation about +Y in degrees (DESIGN.md b, before
    ``b_direction``), ``rapid (N,)`` bool, ``feed (N,)`` mm/min (nan for rapids), ``spindle
    (N,)`` rpm in effect (+ CW/M3, - CCW/M4, 0 stopped, nan unknown), ``coolant (N,)`` in effect
    (0 off, 7 mist, 8 flood, -1 unknown), ``tool (N,)`` in effect (0 unknown), ``comment`` one
    text per move ('' none; flagged points), ``line (N,)`` source line of each move, ``source``
    the CL file (named in errors), ``units`` the job's units ('mm' or 'inch'): the program is
    written in them (None: the machine's)."""

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

    @classmethod
    def build(
        cls,
        tip: np.ndarray,
        b_deg: np.ndarray,
        *,
        rapid: np.ndarray | None = None,
        feed: np.ndarray | float | None = None,
        spindle: np.ndarray | float | None = None,
        coolant: np.ndarray | int | None = None,
        tool: np.ndarray | int | None = None,
        comment: list[str] | tuple[str, ...] | None = None,
        line: np.ndarray | None = None,
        source: str | None = None,
        units: str | None = None,
    ) -> PostMoves:
        """Moves from tips ``(N,3)`` and B ``(N,)`` degrees, the axis following from B; scalars
        broadcast, missing fields take their 'unknown' value."""
        tip = np.asarray(tip, dtype=float).reshape(-1, 3)
        n = len(tip)
        b = np.broadcast_to(np.asarray(b_deg, dtype=float), (n,)).copy()

        def full(value, default, dtype):
            return np.broadcast_to(
                np.asarray(default if value is None else value, dtype=dtype), (n,)
            ).copy()

        return cls(
            tip=tip,
            axis=axis_from_rotation(np.radians(b)),
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
) -> PostMoves:
    """PostMoves from a `checker.toolpath.ToolPath`: the rows of
    ``toolpath.motion_arrays(arc_chord_tol)`` (arcs cut into chords of that sagitta, mm; None:
    the config's ``check.arc_chord_tolerance``, the rows the checker sees) with their rapid
    flag, feed, spindle, coolant (where the arrays carry it), line and the tool number of their
    operation. With ``b_deg (N,)`` (the chosen B, degrees) the axis becomes ``(-sin b, 0, cos
    b)``, else B follows from the CL axis; with ``cc (N,3)``, ``normals (N,3)`` (part frame,
    out of the material) and ``cutter`` the tip is recomputed from the contact by
    ``cutter.tip_from_contact(cc, n, axis)`` at the new axis. ``comments`` (one per row, ''
    none) are written before the blocks (flags). ``tip (N,3)`` (part frame, mm) replaces the
    CL tips outright (the checker's recomputed tips at the chosen B)."""
    if arc_chord_tol is None:
        arc_chord_tol = default_config().check.arc_chord_tolerance
    arrays = toolpath.motion_arrays(arc_chord_tol)
    lines = np.asarray(arrays.line)
    if b_deg is None:
        b = rotation_from_axis(
            np.asarray(arrays.axis, dtype=float),
            j_tolerance=default_config().four_axis.axis_j_tolerance,
            lines=lines,
            path=str(toolpath.path),
        )
    else:
        b = np.asarray(b_deg, dtype=float)
    tip = np.asarray(arrays.tip if tip is None else tip, dtype=float)
    if cc is not None and normals is not None and cutter is not None:
        axis = axis_from_rotation(np.radians(b))
        tip = np.asarray(
            cutter.tip_from_contact(np.asarray(cc, float), np.asarray(normals, float), axis)
        )
    numbers = np.array([op.tool_number or 0 for op in toolpath.operations] or [0], dtype=int)
    return PostMoves.build(
        tip,
        b,
        rapid=arrays.rapid,
        feed=arrays.feed,
        spindle=arrays.spindle,
        coolant=getattr(arrays, "coolant", None),  # where the CL reader records COOLNT
        tool=numbers[np.asarray(arrays.op, dtype=int)],
        comment=comments,
        line=lines,
        source=str(toolpath.path),
        units=toolpath.units,
    )


def machine_for_toolpath(toolpath, name: str | None = None) -> Machine:
    """The machine to post ``toolpath`` for: ``name`` (a machine name or .toml file) when given,
    else the CL file's ``PPRINT/MACHINE NAME``, else the default machine (fanuc-hmc)."""
    if name is None:
        for record in toolpath.records:
            words = (record.text or "").split() if record.word == "PPRINT" else []
            if len(words) == 2 and words[0].upper() == "MACHINE":
                name = words[1]
                break
    return load_machine(name)


@dataclass
class PostedProgram:
    """The program text and, per written row, its program line (1-based, -1 when the block was
    empty and omitted), its source move (-1 inserted) and whether it ends that source move."""

    text: str
    rows: Rows = field(repr=False)


def _validate(moves: PostMoves, machine: Machine) -> None:
    n = len(moves)
    for name in ("axis", "b_deg", "rapid", "feed", "spindle", "coolant", "tool", "line"):
        if len(getattr(moves, name)) != n:
            raise PathcheckError(
                f"PostMoves.{name} has {len(getattr(moves, name))} rows, expected {n}", code="post"
            )
    if len(moves.comment) != n:
        raise PathcheckError(
            f"PostMoves.comment has {len(moves.comment)} rows, expected {n}", code="post"
        )
    if n == 0:
        raise PathcheckError("nothing to post: the tool path has no moves", code="post")
    finite = np.isfinite(moves.tip).all(axis=1) & np.isfinite(moves.b_deg)
    if not finite.all():
        k = int(np.flatnonzero(~finite)[0])
        raise PathcheckError(
            "move has a non-finite tip or B",
            path=moves.source,
            line=int(moves.line[k]),
            code="post",
        )
    mismatch = (
        np.linalg.norm(moves.axis - axis_from_rotation(np.radians(moves.b_deg)), axis=1) > 1e-6
    )
    if mismatch.any():
        k = int(np.flatnonzero(mismatch)[0])
        raise PathcheckError(
            f"tool axis {tuple(np.round(moves.axis[k], 6))} does not match "
            f"B = {moves.b_deg[k]:.4f} deg: expected (-sin B, 0, cos B)",
            path=moves.source,
            line=int(moves.line[k]),
            code="post",
        )
    no_feed = ~moves.rapid & ~(moves.feed > 0)
    if no_feed.any():
        k = int(np.flatnonzero(no_feed)[0])
        raise PathcheckError(
            "feed move without a feed rate: expected a FEDRAT > 0 before it",
            path=moves.source,
            line=int(moves.line[k]),
            code="post",
        )


def _pieces(moves: PostMoves, machine: Machine) -> dict[str, np.ndarray]:
    """Source moves as machine rows, split so no block turns MAX_STEP degrees or more."""
    w = machine.kinematics.b_direction * np.unwrap(moves.b_deg, period=360.0)
    xyz = part_to_machine(moves.tip, w, machine)
    count = pieces_per_move(w)
    src = np.repeat(np.arange(len(moves)), count)
    j = np.arange(src.size) - np.repeat(np.cumsum(count) - count, count) + 1
    t = (j / count[src])[:, None]
    prev = np.maximum(src - 1, 0)
    return {
        "xyz": xyz[prev] + t * (xyz[src] - xyz[prev]),
        "wc": w[prev] + t[:, 0] * (w[src] - w[prev]),
        "src": src,
        "end": j == count[src],
        "feed_move": ~moves.rapid[src],
    }


def _starts(moves: PostMoves) -> np.ndarray:
    """Source moves that begin with an approach: the first move and every tool change."""
    change = np.flatnonzero(np.diff(moves.tool) != 0) + 1
    return np.union1d([0], change)


def _big_turns(moves: PostMoves, machine: Machine) -> np.ndarray:
    """Cuts (not starts) whose B turns more than ``rotary.max_turn_in_cut`` degrees: made as
    retract, rotate, re-enter."""
    turn = np.abs(np.diff(np.unwrap(moves.b_deg, period=360.0), prepend=moves.b_deg[:1]))
    big = (turn > machine.rotary.max_turn_in_cut) & ~moves.rapid
    big[_starts(moves)] = False
    return np.flatnonzero(big)


def _row(
    xyz, word, turn, motion, src, *, end=False, g43=False, force=False
) -> dict[str, np.ndarray]:
    return {
        "xyz": np.asarray(xyz, float).reshape(1, 3),
        "word": np.array([word], float),
        "turn": np.array([turn], float),
        "motion": np.array([motion], int),
        "src": np.array([src], int),
        "end": np.array([end]),
        "g43": np.array([g43]),
        "force": np.array([force]),
    }


def _assemble(moves: PostMoves, machine: Machine) -> dict[str, np.ndarray]:
    """All machine rows in program order: the split source moves plus approach and
    retract-rotate-re-enter rows. ``turn`` is the table position the control reaches (degrees,
    continuous), used for block times."""
    p = _pieces(moves, machine)
    rot = machine.rotary
    span = rot.word_range()
    if span is None:
        word = rollover_words(p["wc"], rot.wrap, machine.format.rotary_decimals)
        branch = np.zeros(p["src"].size, dtype=int)
        turn = p["wc"]
    else:
        branch = range_branches(p["wc"], *span, lines=moves.line[p["src"]], path=moves.source)
        word = p["wc"] + 360.0 * branch
        turn = word
    m = p["src"].size
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
    whole = np.union1d(starts, _big_turns(moves, machine))  # moves kept as their end row only
    first = np.searchsorted(p["src"], whole, "left")
    last_piece = np.searchsorted(p["src"], whole, "right") - 1
    skip = np.zeros(m, bool)
    for a, b in zip(first, last_piece, strict=True):
        skip[a:b] = True
    approach = set(last_piece[np.isin(whole, starts)].tolist())
    reenter = {int(i): int(f) for i, f in zip(last_piece, first, strict=True) if i not in approach}
    jumps = {int(i) for i in np.flatnonzero(np.diff(branch) != 0) + 1 if not skip[i]}
    jumps -= approach | set(reenter)
    clearance = machine.program.reentry_clearance
    safe = machine.program.safe_z
    chunks: list[dict[str, np.ndarray]] = []
    last = 0
    for i in sorted(approach | jumps | set(reenter)):
        keep = ~skip[last:i]
        chunks.append({key: val[last:i][keep] for key, val in rows.items()})
        x, y, z = rows["xyz"][i]
        k = int(rows["src"][i])
        here = {key: val[i : i + 1] for key, val in rows.items()}
        if i in approach:
            tool = int(moves.tool[k]) > 0
            if not tool:  # no tool change retracted the spindle: go to the safe plane first
                chunks.append(_row([np.nan, np.nan, safe], np.nan, turn[i], 0, k, force=True))
            chunks.append(_row([x, y, np.nan], word[i], turn[i], 0, k, force=True))
            if rows["motion"][i] == 0:
                here = {**here, "g43": np.array([tool]), "force": np.array([True])}
            else:
                chunks.append(
                    _row([x, y, z + clearance], word[i], turn[i], 0, k, g43=tool, force=True)
                )
        elif rows["motion"][i] == 0 or i in reenter:
            # a rapid across the end of the word range, or a cut turning too far: retract from
            # the previous point, turn the table, come back over the end point (feed in if a cut)
            j = reenter.get(i, i) - 1
            xp, yp, zp = rows["xyz"][j]
            up = max(safe, zp)
            chunks += [
                _row([xp, yp, up], word[j], turn[j], 0, k),
                _row([xp, yp, up], word[i], turn[i], 0, k),
                _row([x, y, up], word[i], turn[i], 0, k),
            ]
            if rows["motion"][i] == 1:
                chunks.append(_row([x, y, z + clearance], word[i], turn[i], 0, k))
        else:  # a cut across the end of the word range: split there, retract, turn back, re-enter
            chunks += _crossing(rows, i, span, machine, moves)
        chunks.append(here)
        last = i + 1
    keep = ~skip[last:]
    chunks.append({key: val[last:][keep] for key, val in rows.items()})
    return {key: np.concatenate([c[key] for c in chunks]) for key in rows}


def _crossing(
    rows, i: int, span: tuple[float, float], machine: Machine, moves: PostMoves
) -> list[dict]:
    """Rows that replace the first part of cut ``i`` whose B word must change branch: cut to the
    range end, retract to safe Z, turn a full turn back, rapid down, feed in."""
    lo, hi = span
    k = int(rows["src"][i])
    w0 = rows["word"][i - 1]
    # the B change of this block as the path turns (|delta| < MAX_STEP), on the old branch
    delta = (rows["word"][i] - w0 + 180.0) % 360.0 - 180.0
    bound = hi if delta > 0 else lo
    t = (bound - w0) / delta
    xyz = rows["xyz"][i - 1] + t * (rows["xyz"][i] - rows["xyz"][i - 1])
    new_word = bound - 360.0 if delta > 0 else bound + 360.0
    if not lo - 1e-9 <= new_word <= hi + 1e-9:
        raise PathcheckError(
            f"B must pass {bound:g} deg during a cut, and the B word range "
            f"[{lo:g}, {hi:g}] is less than a full turn: no retract-rotate-re-enter can "
            "continue the cut",
            path=moves.source,
            line=int(moves.line[k]),
            code="travel",
        )
    up = max(machine.program.safe_z, xyz[2])
    out = []
    if t > 1e-9:
        out.append(_row(xyz, bound, bound, 1, k))
    return out + [
        _row([xyz[0], xyz[1], up], bound, bound, 0, k),
        _row([xyz[0], xyz[1], up], new_word, new_word, 0, k),
        _row(
            [xyz[0], xyz[1], xyz[2] + machine.program.reentry_clearance], new_word, new_word, 0, k
        ),
        _row(xyz, new_word, new_word, 1, k),
    ]


def _feed_words(rows: dict[str, np.ndarray], moves: PostMoves, machine: Machine) -> np.ndarray:
    """F word ``(M,)`` of each feed row (nan elsewhere). Block time ``t = max(L / feed, |dB| /
    rotary max, |dXYZ| / linear max)`` minutes, L the tip path length relative to the part; G93:
    ``F = 1 / t``; G94 (the rotary rule): ``F = D / t`` with D the distance the dialect's control
    applies F to, so the control's block time is ``t`` (and t >= D / linear max, so the control
    never clamps F)."""
    out = np.full(rows["motion"].size, np.nan)
    i = np.flatnonzero(rows["motion"] == 1)
    prev = i - 1
    xyz0, xyz1 = rows["xyz"][prev], rows["xyz"][i]
    turn0, turn1 = rows["turn"][prev], rows["turn"][i]
    length = tip_path_length(xyz0, xyz1, turn0, turn1, machine)
    dxyz = xyz1 - xyz0
    dturn = turn1 - turn0
    scale = 1.0 / MM_PER_INCH if machine.units == "inch" else 1.0
    limits = [
        length / moves.feed[rows["src"][i]],
        np.abs(dturn) / machine.rotary.max_feed,
        np.linalg.norm(dxyz, axis=1) / machine.feeds.max_linear,
    ]
    g93 = machine.feeds.rotary_mode == "g93"
    distance = get_dialect(machine.dialect).feed_distance(dxyz * scale, dturn)
    if not g93:
        limits.append(distance / (machine.feeds.max_linear * scale))
    t = np.maximum.reduce(limits)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = 1.0 / t if g93 else distance / t
    out[i] = np.where(t > 0, f, np.nan)
    return out


def _spindle_block(rpm: float, code) -> str:
    if rpm == 0:
        return code("M", 5)
    return f"S{abs(rpm):g} {code('M', 3 if rpm > 0 else 4)}"


def _pre_blocks(
    rows: dict[str, np.ndarray], moves: PostMoves, machine: Machine
) -> dict[int, list[str]]:
    """Blocks before the first row of a source move: its comment (flag), a note where a cut turns
    too far for cutting, tool change, spindle, coolant, each written only where it changes (and
    again after a tool change)."""
    code = get_dialect(machine.dialect).format_code
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
    big = np.zeros(n, bool)
    big[_big_turns(moves, machine)] = True
    pre: dict[int, list[str]] = {}
    events = np.flatnonzero(has_comment | big | toolchange | spindle_change | coolant_change)
    row_of = dict(zip(src_ids.tolist(), first_row.tolist(), strict=True))
    for k in events.tolist():
        blocks = []
        if has_comment[k]:
            blocks.append(comment(moves.comment[k]))
        if big[k]:
            db = moves.b_deg[k] - moves.b_deg[k - 1]
            db = (db + 180.0) % 360.0 - 180.0
            blocks.append(
                comment(
                    f"B turns {db:+.3f} deg in one cut (line {int(moves.line[k])}): retract, "
                    "rotate, re-enter"
                )
            )
        if toolchange[k]:
            blocks += [t.format(tool=int(moves.tool[k])) for t in machine.program.tool_change]
        if spindle_change[k]:
            blocks.append(_spindle_block(float(moves.spindle[k]), code))
        if coolant_change[k]:
            blocks.append(code("M", {0: 9, 7: 7, 8: 8}.get(int(moves.coolant[k]), 8)))
        pre[row_of[k]] = blocks
    return pre


def _check_travel(rows: Rows, text: str, machine: Machine, moves: PostMoves) -> None:
    """A travel-limit violation is an error naming the block, its program line and source line."""
    limits = np.array([machine.travel.x, machine.travel.y, machine.travel.z])
    with np.errstate(invalid="ignore"):
        bad = (rows.xyz < limits[:, 0] - 1e-9) | (rows.xyz > limits[:, 1] + 1e-9)
    bad &= (rows.line > 0)[:, None]
    if not bad.any():
        return
    i, axis = (int(v) for v in np.argwhere(bad)[0])
    program_line = int(rows.line[i])
    block = text.splitlines()[program_line - 1]
    lo, hi = limits[axis]
    raise PathcheckError(
        f"travel limit: block '{block}' (program line {program_line}) moves {'XYZ'[axis]} to "
        f"{rows.xyz[i, axis]:.4f} mm, expected within [{lo:g}, {hi:g}] of machine '{machine.name}'",
        path=moves.source,
        line=int(moves.line[rows.src[i]]),
        code="travel",
    )


def post(moves: PostMoves, machine: Machine, *, program_name: str = "PATHCHECK") -> PostedProgram:
    """Post ``moves`` for ``machine`` in the job's units: the program text and the row table
    (see PostedProgram)."""
    _validate(moves, machine)
    if moves.units is not None and moves.units != machine.units:
        machine = machine.model_copy(update={"units": moves.units})
    assembled = _assemble(moves, machine)
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
    pre = _pre_blocks(assembled, moves, machine)
    text = format_program(rows, machine, get_dialect(machine.dialect), pre, program_name)
    _check_travel(rows, text, machine, moves)
    return PostedProgram(text=text, rows=rows)


def post_program(moves: PostMoves, machine: Machine, *, program_name: str = "PATHCHECK") -> str:
    """G-code text for ``moves`` on ``machine`` (see `post`)."""
    return post(moves, machine, program_name=program_name).text


def post_toolpath(
    toolpath,
    out: str | Path,
    *,
    machine: str | None = None,
    b_deg=None,
    cc=None,
    normals=None,
    cutter=None,
    comments: list[str] | None = None,
    arc_chord_tol: float | None = None,
    tip=None,
) -> Path:
    """The job's corrected G-code in one call (what `pathcheck JOB.apt -o JOB.nc [--machine
    NAME]` needs): the machine by `machine_for_toolpath`, the moves by `moves_from_toolpath`
    (same arguments), posted and written atomically to ``out``; returns the path written."""
    moves = moves_from_toolpath(
        toolpath, b_deg, cc, normals, cutter, arc_chord_tol=arc_chord_tol, comments=comments,
        tip=tip,
    )
    name = Path(str(toolpath.path)).stem.upper() or "PATHCHECK"
    text = post_program(moves, machine_for_toolpath(toolpath, machine), program_name=name)
    return write_program(text, out)
