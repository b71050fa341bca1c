"""File -> `ToolPath`: decode, refuse binary input, detect the dialect, lex, interpret.

A file is read twice in blocks, never whole: a first pass finds its encoding (UTF-8, else
Latin-1), line ends, dialect and card-image layout and refuses binary data; the second lexes it
line by line into arrays (`checker.apt.lexer`). A UTF-8 byte-order mark is skipped; a file whose
lines end in CR alone (classic Mac OS) is read by those line ends."""

from __future__ import annotations

import codecs
import re
from dataclasses import dataclass
from pathlib import Path

from checker.apt.dialect import DialectScan, is_cl_text
from checker.apt.interpret import interpret
from checker.apt.lexer import card_counts, is_card_image, lex
from checker.errors import PathcheckError
from checker.toolpath import ToolPath

# control characters that never occur in text (tab, LF, FF and CR do)
_BINARY = re.compile(r"[\x00-\x08\x0b\x0e-\x1f\x7f]")
_NONBLANK = re.compile(r"\S")
SNIFF_BYTES = 64 * 1024  # how much of a file `is_cl_file` reads
BLOCK_BYTES = 1 << 20  # how much of a file the first pass reads at a time
BOM = codecs.BOM_UTF8
EOF_MARK = "\x1a"  # a DOS end-of-file mark, allowed at the end of a file


def _decode(data: bytes) -> str:
    """Text of a CL file: UTF-8 (a byte-order mark skipped), else Latin-1 (CAM comments in
    Windows code pages)."""
    data = data.removeprefix(BOM)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


@dataclass
class _Layout:
    """What the first pass found: line separator, card-image layout, dialect, emptiness."""

    newline: str = "\n"
    column72: bool = False
    dialect: str = "apt"
    empty: bool = True


class _Scan:
    """The first pass over a text given in pieces that end at line ends (`feed`)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.dialect = DialectScan()
        self.lines_before = 0  # line ends in the pieces fed so far
        self.nonblank = self.eighty = 0
        self.has_lf = self.has_cr = False
        self.empty = True

    def feed(self, text: str, end: int | None = None) -> None:
        """Scan ``text[:end]``, whole lines."""
        end = len(text) if end is None else end
        lf = text.find("\n", 0, end) >= 0
        cr = text.find("\r", 0, end) >= 0
        self.has_lf |= lf
        self.has_cr |= cr
        if cr and not lf:  # CR line ends: read as LF for the line-anchored scans
            text = text[:end].replace("\r", "\n")
        m = _BINARY.search(text, 0, end)
        if m is not None:
            raise PathcheckError(
                f"expected a text CL file, found binary data (byte 0x{ord(m.group()):02x})",
                path=self.path,
                line=self.lines_before + text.count("\n", 0, m.start()) + 1,
                code="parse",
            )
        self.empty = self.empty and _NONBLANK.search(text, 0, end) is None
        self.dialect.feed(text, end)
        nonblank, eighty = card_counts(text, end)
        self.nonblank += nonblank
        self.eighty += eighty
        self.lines_before += text.count("\n", 0, end)

    def layout(self, column72: bool | None) -> _Layout:
        if self.empty:
            raise PathcheckError(
                "empty file: expected CL statements (GOTO/, CUTTER/, ...), found nothing",
                path=self.path,
                code="parse",
            )
        return _Layout(
            newline="\r" if self.has_cr and not self.has_lf else "\n",
            column72=is_card_image(self.nonblank, self.eighty) if column72 is None else column72,
            dialect=self.dialect.result(self.path),
            empty=False,
        )


def read_cl_text(
    text: str,
    path: str = "<string>",
    *,
    column72: bool | None = None,
    require_cutter: bool = True,
) -> ToolPath:
    """A tool path from CL text. ``column72``: ignore text after column 72 (None: only for
    80-column card images). ``require_cutter``: a feed move before any cutter is an error."""
    text = text.removeprefix("\ufeff").rstrip(EOF_MARK)
    scan = _Scan(path)
    scan.feed(text)
    layout = scan.layout(column72)
    records = lex(text.split(layout.newline), path=path, column72=layout.column72,
                  header_comments=layout.dialect == "clsf")
    return interpret(records, path=path, dialect=layout.dialect, require_cutter=require_cutter)


def _cannot_read(path: Path, err: OSError) -> PathcheckError:
    return PathcheckError(f"cannot read CL file: {err.strerror or err}", path=path, code="io")


def _first_pass(path: Path, encoding: str, column72: bool | None, skip: int = 0) -> _Layout:
    """The `_Layout` of the file read in blocks as ``encoding`` after its first ``skip``
    bytes; UnicodeDecodeError when it is not that encoding."""
    scan = _Scan(str(path))
    decoder = codecs.getincrementaldecoder(encoding)()
    carry = ""
    with path.open("rb") as fh:
        fh.seek(skip)
        while True:
            block = fh.read(BLOCK_BYTES)
            final = not block
            text = carry + decoder.decode(block, final=final)
            del block
            if final:
                scan.feed(text.rstrip(EOF_MARK))
                break
            cut = max(text.rfind("\n"), text.rfind("\r")) + 1
            if text.endswith("\r"):  # "\r\n" split by the block: keep them together
                cut -= 1
            carry = text[cut:]
            scan.feed(text, cut)
            del text
    return scan.layout(column72)


def read_cl(
    path: str | Path, *, column72: bool | None = None, require_cutter: bool = True
) -> ToolPath:
    """The tool path of an APT-CL or NX CLSF file; bad input raises PathcheckError."""
    p = Path(path)
    try:
        with p.open("rb") as fh:
            bom = fh.read(len(BOM)) == BOM
        try:
            encoding = "utf-8"
            layout = _first_pass(p, "utf-8-sig", column72)
        except UnicodeDecodeError:
            encoding = "latin-1"
            layout = _first_pass(p, "latin-1", column72, len(BOM) if bom else 0)
        with p.open("r", encoding="utf-8-sig" if encoding == "utf-8" else encoding,
                    newline=layout.newline) as fh:
            if bom and encoding == "latin-1":
                fh.read(len(BOM))
            records = lex(fh, path=str(p), column72=layout.column72,
                          header_comments=layout.dialect == "clsf")
    except OSError as err:
        raise _cannot_read(p, err) from None
    return interpret(records, path=str(p), dialect=layout.dialect,
                     require_cutter=require_cutter)


def is_cl_file(path: str | Path) -> bool:
    """Whether a file is CL text by its content, whatever its suffix (an NX CLSF listing saved
    as `.txt`): its first SNIFF_BYTES are text, not binary, with CL statements
    (`is_cl_text`). A file that cannot be read is not."""
    try:
        with Path(path).open("rb") as fh:
            head = _decode(fh.read(SNIFF_BYTES))
    except OSError:
        return False
    if "\n" not in head:
        head = head.replace("\r", "\n")
    return _BINARY.search(head.rstrip("\x1a")) is None and is_cl_text(head)
