"""CL lines -> a `RecordList`: `$` continuation, `$$` comments, free-text statements, column-72
card images, numbers checked (finite, at most MAX_ABS; for plain GOTOs the interpreter checks the
magnitude in bulk). Plain GOTOs go into growing arrays, not objects, so that a program of
millions of moves is read in tens of bytes a move. No meaning is given to any word here."""

from __future__ import annotations

import math
import re
from array import array
from collections.abc import Iterable

import numpy as np

from checker.errors import PathcheckError
from checker.input_limits import MAX_CL_STATEMENTS, refuse_beyond
from checker.toolpath import Record, RecordList, Value

# statements whose text after "/" is literal (commas, slashes and "$" included)
FREE_TEXT = frozenset({"PARTNO", "PPRINT", "INSERT", "TITLE", "REMARK"})
# a number as APT writes it: 5.  .5  -0.173648  1.0E+02  1.0D+02
_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][+-]?\d+)?"
_NUM_RE = re.compile(_NUM)
# plain decimals of at most 15 integer digits (so |v| < MAX_ABS), no blanks
_FAST = r"[+-]?(?:\d{1,15}(?:\.\d*)?|\.\d+)"
_FAST_NUMS = re.compile(rf"{_FAST}(?:,{_FAST})*")
# the GOTO fast path: only these characters, then float(); the interpreter checks magnitudes
_PLAIN = re.compile(r"[0-9.,+-]*")
_STATEMENT = re.compile(r"([A-Za-z][A-Za-z0-9_\-]*(?: [A-Za-z][A-Za-z0-9_\-]*)*)\s*(/?)(.*)", re.S)
_WORD_TOKEN = re.compile(r"[\x21-\x7e](?:[\x20-\x7e]*[\x21-\x7e])?")
_HAS_LETTER = re.compile(r"[A-Za-z]")
_NX_TRAILER = re.compile(r"Tool Path Listing has \d+ lines\.?")
MAX_ABS = 1e15  # larger numbers are malformed input, not coordinates


def _show(text: str, limit: int = 40) -> str:
    text = text.strip()
    return repr(text if len(text) <= limit else text[:limit] + "...")


def parse_args(raw: str, word: str, *, path: str, line: int) -> tuple[Value, ...]:
    """The comma-separated values after ``WORD/``: floats or upper-case minor words."""
    if not raw.strip():
        return ()
    if _FAST_NUMS.fullmatch(raw):
        return tuple(map(float, raw.split(",")))
    out: list[Value] = []
    for pos, tok in enumerate(raw.split(","), start=1):
        tok = tok.strip()
        if not tok:
            raise PathcheckError(
                f"{word}/: expected a value at position {pos}, found an empty field",
                path=path,
                line=line,
                code="parse",
            )
        if _NUM_RE.fullmatch(tok):
            v = float(tok.replace("D", "E").replace("d", "e"))
            if not (math.isfinite(v) and abs(v) <= MAX_ABS):
                raise PathcheckError(
                    f"{word}/: expected a finite number of at most {MAX_ABS:g} at position "
                    f"{pos}, found {_show(tok)}",
                    path=path,
                    line=line,
                    code="parse",
                )
            out.append(v)
        elif _HAS_LETTER.search(tok) and _WORD_TOKEN.fullmatch(tok):
            out.append(tok.upper())
        else:
            raise PathcheckError(
                f"{word}/: expected a number or a word at position {pos}, found malformed "
                f"{_show(tok)}",
                path=path,
                line=line,
                code="parse",
            )
    return tuple(out)


# zero-width matches: `findall` lists the one empty string, 8 bytes a line
_NONBLANK = re.compile(r"^(?=[^\S\n]*\S)", re.M)
_EIGHTY = re.compile(r"^(?=(?=[^\n]*\S)[^\n]{79}[^\r\n]\r*$)", re.M)


def card_counts(text: str, end: int | None = None) -> tuple[int, int]:
    """(non-blank lines, those exactly 80 characters wide without their CRs) of the whole
    lines of ``text[:end]``."""
    end = len(text) if end is None else end
    return len(_NONBLANK.findall(text, 0, end)), len(_EIGHTY.findall(text, 0, end))


def is_card_image(nonblank: int, eighty: int) -> bool:
    """True for 80-column card images (sequence numbers in columns 73-80): at least 90 % of the
    non-blank lines are exactly 80 characters wide (counts from `card_counts`)."""
    return nonblank > 0 and eighty >= 0.9 * nonblank


def _split_comment(body: str) -> tuple[str, str | None]:
    """``'GOTO/1,2,3 $$ note'`` -> ``('GOTO/1,2,3', ' note')``."""
    k = body.find("$$")
    if k < 0:
        return body, None
    return body[:k].rstrip(), body[k + 2 :].rstrip()


def _statement(text: str) -> tuple[str, bool, str] | None:
    """``(WORD, has_slash, rest)`` of a statement, None when the text is not one."""
    m = _STATEMENT.fullmatch(text)
    if m is None or (not m.group(2) and m.group(3).strip()):
        return None
    return " ".join(m.group(1).upper().split()), bool(m.group(2)), m.group(3)


def lex(
    lines: Iterable[str], *, path: str, column72: bool, header_comments: bool
) -> RecordList:
    """Records of the file from its lines (line ends kept or not). ``header_comments``: lines
    before the first statement that are not statements (the NX "Information listing" header)
    and its "Tool Path Listing has N lines." trailer become comment records. More than
    MAX_CL_STATEMENTS records other than plain GOTOs is an error."""
    records: list[Record] = []
    at = array("q")  # positions of `records` in the whole sequence
    xyz, glines = array("d"), array("i")  # plain GOTOs
    axis_rows, axis_values = array("q"), array("d")
    xyz_extend, glines_append = xyz.extend, glines.append
    pending: list[str] = []
    pending_line = 0
    comment: str | None = None
    seen_statement = False
    plain = _PLAIN.fullmatch

    def append(rec: Record) -> None:
        if len(records) >= MAX_CL_STATEMENTS:
            refuse_beyond(len(records) + 1, MAX_CL_STATEMENTS,
                          "or more statements other than plain GOTOs", "MAX_CL_STATEMENTS",
                          path=path, line=rec.line)
        at.append(len(records) + len(glines))
        records.append(rec)

    for no, raw in enumerate(lines, start=1):
        s = (raw[:72] if column72 else raw).rstrip()
        if not pending and s.startswith("GOTO/") and plain(s, 5):
            # the common case, kept lean; malformed numbers get parse_args's message
            try:
                vals = tuple(map(float, s[5:].split(",")))
            except ValueError:
                vals = parse_args(s[5:], "GOTO", path=path, line=no)
            seen_statement = True
            if len(vals) == 3:
                xyz_extend(vals)
                glines_append(no)
            elif len(vals) == 6:
                axis_rows.append(len(glines))
                axis_values.extend(vals[3:])
                xyz_extend(vals[:3])
                glines_append(no)
            else:  # the interpreter names the count
                append(Record("GOTO", vals, no))
            continue
        if "\x1a" in s:  # a DOS end-of-file mark (the reader refuses it elsewhere)
            s = s.replace("\x1a", "").rstrip()
        stripped = s.strip()
        if not stripped:
            continue
        if stripped.startswith("$$"):
            append(Record("$$", (), no, text=stripped[2:]))
            continue
        if not pending:
            head = _statement(stripped)
            if head is None and header_comments and (
                not seen_statement or _NX_TRAILER.fullmatch(stripped)
            ):
                append(Record("$$", (), no, text=" " + stripped))
                continue
            seen_statement = True
            if head is not None and head[0] in FREE_TEXT and head[1]:
                append(Record(head[0], (), no, text=head[2].rstrip()))
                continue
            pending_line, comment = no, None
        body, note = _split_comment(stripped)
        comment = note if note is not None else comment
        if body.endswith("$"):
            pending.append(body[:-1])
            continue
        pending.append(body)
        text, pending = "".join(pending), []
        head = _statement(text)
        if head is None:
            raise PathcheckError(
                f"expected a statement WORD/values, found {_show(text)}",
                path=path,
                line=pending_line,
                code="parse",
            )
        word, slash, rest = head
        args = parse_args(rest, word, path=path, line=pending_line)
        append(Record(word, args, pending_line, comment=comment, slash=slash))
    if pending:
        raise PathcheckError(
            "statement continued with '$' but the file ends: expected a continuation line",
            path=path,
            line=pending_line,
            code="parse",
        )
    return RecordList(records, np.frombuffer(at, dtype=np.int64),
                      np.frombuffer(xyz, dtype=float).reshape(-1, 3),
                      np.frombuffer(glines, dtype=np.int32),
                      np.frombuffer(axis_rows, dtype=np.int64),
                      np.frombuffer(axis_values, dtype=float).reshape(-1, 3))
