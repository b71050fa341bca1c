"""G-code writer: machine rows (already in machine coordinates and B words) to program text in a
dialect, with modal words suppressed, block numbers, header and footer; and the atomic file
write (`checker.atomic`) so a failed run never leaves half a program."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.atomic import write_file
from checker.postproc.dialects import Dialect
from checker.postproc.machine import Machine
from checker.units import mm_per_unit

_TRAILING_ZEROS = re.compile(r"0+$", re.M)
_DOT_END = re.compile(r"\.$", re.M)
_NO_DOT = re.compile(r"$", re.M)


@dataclass
class Rows:
    """Program rows in program order. ``xyz (M,3)`` program X Y Z mm (machine coordinates, or
    work-frame tips with tool-centre-point control; nan: not commanded), ``word (M,k)`` rotary
    words (deg) in the machine's axis order, ``turn (M,k)`` continuous rotary positions (deg),
    ``motion (M,)`` 0 rapid
    / 1 feed, ``fword (M,)`` F word in program units (nan: none), ``g43``/``force`` flags,
    ``src (M,)`` source move, ``end (M,)`` row ends its source move. ``line (M,)`` is filled by
    the writer: the program line (1-based) of the row's block, -1 when nothing changed."""

    xyz: np.ndarray
    word: np.ndarray
    turn: np.ndarray
    motion: np.ndarray
    fword: np.ndarray
    g43: np.ndarray
    force: np.ndarray
    src: np.ndarray
    end: np.ndarray
    tool: np.ndarray
    line: np.ndarray | None = None


def format_number(values: np.ndarray, decimals: int) -> list[str]:
    """Numbers with a decimal point and at least one decimal (``10.0``, ``-0.5``): accepted by
    Fanuc, LinuxCNC and the PyPI parsers. ``-0.0`` keeps its sign (signed rotary words)."""
    flat = np.asarray(values, dtype=float).ravel().tolist()
    if not flat:
        return []
    text = ("\n".join([f"%.{decimals}f"] * len(flat))) % tuple(flat)
    if decimals:
        text = _DOT_END.sub(".0", _TRAILING_ZEROS.sub("", text))
    else:
        text = _NO_DOT.sub(".0", text)
    return text.split("\n")


def _changed(texts: list[str], valid: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Rows whose word differs from the last one written (modal suppression), or forced."""
    arr = np.asarray(texts, dtype=object)
    idx = np.where(valid, np.arange(len(arr)), -1)
    last = np.maximum.accumulate(idx)
    prev = np.concatenate([[-1], last[:-1]])
    prev_text = np.where(prev >= 0, arr[np.maximum(prev, 0)], None)
    return valid & ((arr != prev_text) | force)


def comment(text: str) -> str:
    """A comment block on one line: parentheses inside become brackets, anything but printable
    ASCII becomes '?' (controls take no other characters in comments)."""
    clean = "".join(c if " " <= c <= "~" else "?" for c in " ".join(text.split()))
    return "(" + clean.replace("(", "[").replace(")", "]") + ")"


def _is_comment(text: str) -> bool:
    return text.startswith("(") or text.startswith(";")


def format_program(
    rows: Rows,
    machine: Machine,
    dialect: Dialect,
    pre: dict[int, list[str]],
    program_name: str,
    header: Sequence[str] = (),
) -> str:
    """Program text for ``rows``; ``header`` lines are written as comments right after the
    program start, ``pre[i]`` are blocks written before row ``i`` (comments start with '(' or
    ';'). Block numbers wrap at the machine's ``block_max``. Fills ``rows.line``."""
    fmt = machine.format
    scale = 1.0 / mm_per_unit(machine.units)
    code = dialect.format_code
    m = len(rows.word)
    force = rows.force.astype(bool)
    words = {}
    linear = fmt.linear_decimals(machine.units)
    for j, letter in enumerate("XYZ"):
        vals = np.round(rows.xyz[:, j] * scale, linear) + 0.0  # no "-0.0"
        valid = np.isfinite(vals)
        texts = format_number(np.where(valid, vals, 0.0), linear)
        words[letter] = (texts, _changed(texts, valid, force))
    for j, axis in sorted(enumerate(machine.rotary_axes), key=lambda t: t[1].name):
        signed = axis.wrap == "signed"
        col = rows.word[:, j]
        vals = col if signed else np.round(col, fmt.rotary_decimals) + 0.0
        texts = format_number(np.nan_to_num(vals), fmt.rotary_decimals)
        # signed words: the sign is a direction, the position is the magnitude
        positions = [t.lstrip("-") for t in texts] if signed else texts
        words[axis.name] = (texts, _changed(positions, np.isfinite(col), force))
    inverse = machine.feeds.rotary_mode == "g93"
    feed_ok = np.isfinite(rows.fword)
    if inverse:
        ftexts = _significant(np.where(feed_ok, rows.fword, 1.0), fmt.inverse_time_digits)
    else:
        ftexts = format_number(np.where(feed_ok, rows.fword, 0.0), fmt.feed_decimals)
    motion_texts = [code("G", int(v)) for v in rows.motion]
    any_axis = np.zeros(m, bool)
    for _, changed in words.values():
        any_axis |= changed
    gmotion = _changed(motion_texts, any_axis, force)
    fchanged = feed_ok & any_axis & (rows.motion == 1)
    if not inverse:
        fchanged &= _changed(ftexts, feed_ok & any_axis & (rows.motion == 1), np.zeros(m, bool))

    name = dialect.comment(program_name)[1:].strip(" )")
    lines: list[str] = list(dialect.program_start(name, machine.units, fmt.program_number))
    lines += [dialect.comment(text) for text in header]
    header = machine.program.header
    blocks: list[str] = list(dialect.header if header is None else header)
    blocks.append(dialect.units_code(machine.units))
    blocks.append(dialect.feed_code(93 if inverse else 94))
    number = fmt.block_start
    end = dialect.block_end
    tcp = machine.tcp.enabled
    offset = dialect.tcp_on_block if tcp and "{tool" in dialect.tcp_on_block else (
        dialect.length_offset)

    def emit(text: str) -> None:
        nonlocal number
        if _is_comment(text):
            lines.append(text)
        elif not fmt.block_numbers:
            lines.append(text + end)
        else:
            lines.append(f"N{number} {text}{end}")
            number += fmt.block_increment
            if number > fmt.block_max:
                number = fmt.block_increment

    for text in blocks:
        emit(text)
    row_line = np.full(m, -1, dtype=int)
    for i in range(m):
        for text in pre.get(i, ()):
            emit(text)
        if not any_axis[i]:
            continue
        parts = [motion_texts[i]] if gmotion[i] else []
        g43 = offset.format(tool=int(rows.tool[i])).split() if rows.g43[i] and offset else []
        parts += [w for w in g43 if not w.startswith("H")]
        parts += [f"{letter}{texts[i]}" for letter, (texts, changed) in words.items() if changed[i]]
        parts += [w for w in g43 if w.startswith("H")]
        if fchanged[i]:
            parts.append(f"F{ftexts[i]}")
        emit(" ".join(parts))
        row_line[i] = len(lines)
    footer = machine.program.footer
    if tcp:
        emit(dialect.tcp_off_block)
    for text in dialect.footer if footer is None else footer:
        emit(text)
    lines += dialect.program_end(name, machine.units, fmt.program_number)
    rows.line = row_line
    return "\n".join(lines) + "\n"


def _significant(values: np.ndarray, digits: int) -> list[str]:
    """Positive numbers with ``digits`` significant digits (at least one decimal), in plain
    decimal notation."""
    decimals = np.maximum(1, digits - 1 - np.floor(np.log10(values)).astype(int))
    out = np.empty(len(values), dtype=object)
    for d in np.unique(decimals):
        pick = decimals == d
        out[pick] = format_number(values[pick], int(d))
    return out.tolist()


def write_program(text: str, path: str | Path) -> Path:
    """Write ``text`` to ``path`` atomically (`checker.atomic.write_file`, ASCII); on failure
    the old file (if any) is left untouched."""
    return write_file(path, text, what="G-code", encoding="ascii")
