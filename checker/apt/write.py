"""`ToolPath` -> APT-CL text: every record back in its own units and frame, numbers in their
shortest exact decimal form, lines over 72 characters continued with ``$``."""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import TextIO

import numpy as np

from checker.apt.lexer import FREE_TEXT
from checker.atomic import write_file
from checker.toolpath import Record, ToolPath, Value

MAX_LINE = 72
_POINT_ZERO = re.compile(r"\.0(?=,|$)")  # repr's "5.0" is written "5"


def format_value(v: Value) -> str:
    """``5.0 -> '5'``, ``-0.1736 -> '-0.1736'``, ``1e-05 -> '0.00001'``; words unchanged."""
    if isinstance(v, str):
        return v
    s = repr(v)  # shortest exact form; positional unless it has an exponent
    if "e" in s:
        return np.format_float_positional(v, trim="-")
    return s[:-2] if s.endswith(".0") else s


def format_record(rec: Record) -> list[str]:
    """The lines of one record (several when continued with ``$``)."""
    if rec.word == "$$":
        return [f"$${rec.text or ''}"]
    if rec.text is not None and rec.word in FREE_TEXT:
        return [f"{rec.word}/{rec.text}"]
    head = rec.word + ("/" if rec.slash else "")
    tail = f" $${rec.comment}" if rec.comment is not None else ""
    if not rec.args:
        return [head + tail]
    if str not in map(type, rec.args):  # all numbers: join their reprs at C speed
        joined = ",".join(map(repr, rec.args))
        if "e" not in joined and "n" not in joined:  # no exponent, nan or inf
            joined = _POINT_ZERO.sub("", joined)
            if len(head) + len(joined) <= MAX_LINE:
                return [head + joined + tail]
    parts = [format_value(a) for a in rec.args]
    lines: list[str] = []
    cur = head + parts[0]
    for p in parts[1:]:
        if len(cur) + len(p) + 3 > MAX_LINE:  # room for "," + p + ",$"
            lines.append(cur + ",$")
            cur = "   " + p
        else:
            cur += "," + p
    lines.append(cur + tail)
    return lines


def apt_text(toolpath: ToolPath) -> str:
    """The whole file as one string."""
    out: list[str] = []
    for rec in toolpath.records:
        out.extend(format_record(rec))
    out.append("")
    return "\n".join(out)


def write_apt(toolpath: ToolPath, path_or_stream: str | Path | TextIO) -> None:
    """Write ``toolpath`` as APT-CL to a file path or an open text stream."""
    text = apt_text(toolpath)
    if isinstance(path_or_stream, io.TextIOBase) or hasattr(path_or_stream, "write"):
        path_or_stream.write(text)  # type: ignore[union-attr]
        return
    write_file(Path(path_or_stream), text, what="APT file")  # type: ignore[arg-type]
