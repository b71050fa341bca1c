"""Lexing one G-code block: comments, block delete, words, parameters and bracketed expressions
(rs274ngc and Fanuc macro style), per the dialect's table. Values that cannot be known when
reading (a HAL pin, an unset parameter) are NaN, not an error: they become an error only where a
move needs them."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from checker.errors import PathcheckError
from checker.postproc.dialects import Dialect

_NUMBER = re.compile(r"[0-9]*\.?[0-9]*")
#: plain blocks (letters and numbers only): one regular expression instead of the cursor
_PLAIN = re.compile(r"(?:[A-Z][-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))*")
_PLAIN_WORD = re.compile(r"([A-Z])([-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))")
#: a word whose number runs straight into E and digits: I1e11 is I1 and E11 to a control
_EXPONENT = re.compile(r"[A-Za-z][-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)[eE][-+]?[0-9]+")
_NAMED = re.compile(r"<[^>]*>")  # rs274ngc #<name>: letters and digits that are no words
_FUNCTIONS = {
    "ABS": abs,
    "SQRT": math.sqrt,
    "SIN": lambda v: math.sin(math.radians(v)),
    "COS": lambda v: math.cos(math.radians(v)),
    "TAN": lambda v: math.tan(math.radians(v)),
    "ROUND": round,
    "FIX": math.floor,
    "FUP": math.ceil,
}


@dataclass
class Block:
    """One block: words in order as (letter, value), parameter assignments, comments, and
    whether it is block-deleted (``/``)."""

    words: list[tuple[str, float]] = field(default_factory=list)
    assignments: list[tuple[str, float]] = field(default_factory=list)
    keywords: list[tuple[str, list[float]]] = field(default_factory=list)  # TRAORI, CYCLE81(..)
    comments: list[str] = field(default_factory=list)
    deleted: bool = False


def _closing(raw: str, pos: int, nested: bool) -> int:
    """Index of the ')' closing the '(' at ``pos`` (-1: none); nested pairs count with
    ``nested``."""
    if not nested:
        return raw.find(")", pos)
    depth = 0
    for k in range(pos, len(raw)):
        depth += {"(": 1, ")": -1}.get(raw[k], 0)
        if depth == 0:
            return k
    return -1


def split_comments(
    raw: str, *, path: str | None, line: int, parens: bool = True, nested: bool = False
) -> tuple[str, list[str]]:
    """Code text without comments, and the comments: ``( ... )`` anywhere (unless ``parens`` is
    off: Sinumerik, whose parentheses hold arguments; ``nested`` pairs count), ``;`` to the end
    of the line (LinuxCNC, Sinumerik and Heidenhain comment, Fanuc end of block)."""
    if ("(" not in raw or not parens) and ";" not in raw:
        return raw, []
    comments: list[str] = []
    code: list[str] = []
    pos = 0
    while pos < len(raw):
        ch = raw[pos]
        if ch == "(" and parens:
            end = _closing(raw, pos, nested)
            if end < 0:
                raise PathcheckError(
                    f"comment opened with '(' at column {pos + 1} is not closed: expected ')'",
                    path=path,
                    line=line,
                    code="gcode",
                )
            comments.append(raw[pos + 1 : end].strip())
            pos = end + 1
        elif ch == ";":
            comments.append(raw[pos + 1 :].strip())
            break
        else:
            code.append(ch)
            pos += 1
    return "".join(code), comments


class _Cursor:
    """Recursive-descent reader over a block with spaces removed and letters upper case."""

    def __init__(self, text: str, params: dict[str, float], dialect: Dialect, path, line):
        self.s, self.pos, self.params, self.dialect = text, 0, params, dialect
        self.path, self.line = path, line

    def fail(self, expected: str) -> PathcheckError:
        found = self.s[self.pos : self.pos + 12] or "end of block"
        return PathcheckError(
            f"expected {expected}, found '{found}' in block '{self.s}'",
            path=self.path,
            line=self.line,
            code="gcode",
        )

    def peek(self) -> str:
        return self.s[self.pos] if self.pos < len(self.s) else ""

    def number(self) -> float:
        match = _NUMBER.match(self.s, self.pos)
        text = match.group(0) if match else ""
        if not any(c.isdigit() for c in text):
            raise self.fail("a number")
        value = float(text)
        if not math.isfinite(value):
            raise self.fail("a number of reasonable size")
        self.pos += len(text)
        return value

    def param_name(self) -> str:
        self.pos += 1  # '#'
        if self.peek() == "<":
            if not self.dialect.named_parameters:
                raise self.fail(f"a numbered parameter (#<name> is not {self.dialect.name})")
            end = self.s.find(">", self.pos)
            if end < 0:
                raise self.fail("'>' closing a parameter name")
            name = self.s[self.pos + 1 : end]
            self.pos = end + 1
            return name
        return str(int(self.number()))

    def real(self) -> float:
        """A real value: optional sign, then number, [expression], #parameter or FUNC[...]."""
        sign = 1.0
        while self.peek() in "+-" and self.peek():
            sign = -sign if self.peek() == "-" else sign
            self.pos += 1
        ch = self.peek()
        if ch == "[":
            self.pos += 1
            value = self.expression()
            if self.peek() != "]":
                raise self.fail("']'")
            self.pos += 1
            return sign * value
        if ch == "#":
            return sign * self.params.get(self.param_name(), math.nan)
        letter = self.dialect.parameter_letter
        if letter != "#" and ch == letter and self.s[self.pos + 1 : self.pos + 2].isdigit():
            self.pos += 1  # MillPlus E parameter
            return sign * self.params.get(f"{letter}{int(self.number())}", math.nan)
        for name, fn in _FUNCTIONS.items():
            if self.s.startswith(name + "[", self.pos):
                self.pos += len(name)
                arg = self.real()
                return sign * (fn(arg) if math.isfinite(arg) else math.nan)
        return sign * self.number()

    def expression(self) -> float:
        value = self.term()
        while self.peek() in ("+", "-") and self.peek():
            op = self.s[self.pos]
            self.pos += 1
            rhs = self.term()
            value = value + rhs if op == "+" else value - rhs
        return value

    def term(self) -> float:
        value = self.real()
        while self.peek() in ("*", "/") and self.peek():
            op = self.s[self.pos]
            self.pos += 1
            rhs = self.real()
            value = value * rhs if op == "*" else (value / rhs if rhs else math.nan)
        return value


def lex_block(raw: str, dialect: Dialect, params: dict[str, float], *, path=None, line=0) -> Block:
    """Words of one program line (1-based ``line``). ``params`` are the parameter values before
    this block (rs274 rule: assignments take effect after the block)."""
    code, comments = split_comments(
        raw, path=path, line=line, parens=not dialect.keywords, nested=dialect.nested_comments
    )
    exponent = _EXPONENT.search(_NAMED.sub("", code) if "<" in code else code)
    if exponent:
        raise PathcheckError(
            f"'{exponent.group(0)}': exponent notation, which G-code does not have (a control "
            "reads the number, then an E word): expected a plain decimal number",
            path=path, line=line, code="gcode")
    keywords: list[tuple[str, list[float]]] = []
    if dialect.keywords:
        code = _KEYWORD.sub(lambda m: _keyword(m, keywords, params, dialect, path, line),
                            code.upper())
    text = "".join(code.split()).upper()
    if dialect.block_end and text.endswith(dialect.block_end.strip()):
        text = text[: -len(dialect.block_end.strip())]
    block = Block(comments=comments, keywords=keywords)
    if text.startswith("/"):
        block.deleted = True
        text = text[1:]
    if len(text) < 200 and _PLAIN.fullmatch(text):  # long digit runs go the checked way
        block.words = [(letter, float(value)) for letter, value in _PLAIN_WORD.findall(text)]
        return block
    cur = _Cursor(text, params, dialect, path, line)
    while cur.pos < len(text):
        ch = cur.peek()
        if ch == "#":
            name = cur.param_name()
            if cur.peek() != "=":
                raise cur.fail(f"'=' after parameter #{name}")
            cur.pos += 1
            block.assignments.append((name, cur.real()))
        elif ch in dialect.block_number_letters and not ch.isalpha():
            cur.pos += 1  # Fanuc ':' alignment sequence number
            block.words.append(("N", cur.number()))
        elif ch.isalpha():
            cur.pos += 1
            if cur.peek() == "=" and dialect.letter_assignments:  # MillPlus B=E254
                cur.pos += 1
                block.words.append((ch, cur.real()))
            elif dialect.letter_assignments and re.match(r"[0-9]+=", text[cur.pos :]):
                index = cur.number()
                cur.pos += 1  # '='
                block.assignments.append((f"{ch}{int(index)}", cur.real()))
            else:
                block.words.append((ch, cur.real()))
        else:
            raise cur.fail("a word (a letter and a value)")
    return block


_CYCLE_CALL = re.compile(r"CYCLE[0-9]+")
#: a Sinumerik identifier (two letters or more) with its ( ... ) arguments or its = value
_KEYWORD = re.compile(
    r"(?<![A-Z0-9_.])([A-Z_][A-Z_][A-Z0-9_]*)(\s*\([^)]*\)|\s*=\s*[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))?"
)


def _keyword(match, out: list, params, dialect: Dialect, path, line) -> str:
    """Record a Sinumerik identifier (``TRAORI``, ``SUPA``, ``MCALL``, ``CYCLE81(...)``,
    ``CR=5``) with its arguments (empty ones NaN, text ones NaN) and cut it from the block."""
    name, tail = match.group(1), (match.group(2) or "").strip()
    if name not in dialect.keywords and not _CYCLE_CALL.fullmatch(name):
        raise PathcheckError(
            f"{name} is not a word of the {dialect.name} dialect as read by pathcheck: "
            "expected an address letter with a value, a CYCLEnn(...) call or one of "
            f"{', '.join(sorted(dialect.keywords)[:12])}, ...",
            path=path, line=line, code="gcode")
    args: list[float] = []
    if tail.startswith("("):
        inner = "".join(tail[1:-1].split())
        for item in inner.split(",") if inner else []:
            if not item:
                args.append(math.nan)
                continue
            sub = _Cursor(item, params, dialect, path, line)
            try:
                value = sub.expression()
            except PathcheckError:
                value = math.nan  # text arguments (tool names, messages)
            args.append(value if sub.pos == len(item) else math.nan)
    elif tail.startswith("="):
        args.append(float(tail[1:]))
    out.append((name, args))
    return " "
