"""File -> `ToolPath`: decode, refuse binary input, detect the dialect, lex, interpret."""

from __future__ import annotations

import re
from pathlib import Path

from checker.apt.dialect import detect_dialect, is_cl_text
from checker.apt.interpret import interpret
from checker.apt.lexer import is_card_image, lex
from checker.errors import PathcheckError, read_input
from checker.toolpath import ToolPath

# control characters that never occur in text (tab, LF, FF and CR do)
_BINARY = re.compile(r"[\x00-\x08\x0b\x0e-\x1f\x7f]")
SNIFF_BYTES = 64 * 1024  # how much of a file `is_cl_file` reads


def _decode(data: bytes) -> str:
    """Text of a CL file: UTF-8, else Latin-1 (CAM comments in Windows code pages)."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _refuse_binary(text: str, *, path: str) -> None:
    m = _BINARY.search(text)
    if m is not None:
        raise PathcheckError(
            f"expected a text CL file, found binary data (byte 0x{ord(m.group()):02x})",
            path=path,
            line=text.count("\n", 0, m.start()) + 1,
            code="parse",
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
    if not text.strip():
        raise PathcheckError(
            "empty file: expected CL statements (GOTO/, CUTTER/, ...), found nothing",
            path=path,
            code="parse",
        )
    text = text.rstrip("\x1a")  # a DOS end-of-file mark
    _refuse_binary(text, path=path)
    dialect = detect_dialect(text, path=path)
    lines = text.split("\n")
    if column72 is None:
        column72 = is_card_image([s.rstrip("\r") for s in lines])
    records = lex(lines, path=path, column72=column72, header_comments=dialect == "clsf")
    return interpret(records, path=path, dialect=dialect, require_cutter=require_cutter)


def read_cl(
    path: str | Path, *, column72: bool | None = None, require_cutter: bool = True
) -> ToolPath:
    """The tool path of an APT-CL or NX CLSF file; bad input raises PathcheckError."""
    p = Path(path)
    return read_cl_text(_decode(read_input(p, "CL file", code="io")), str(p),
                        column72=column72, require_cutter=require_cutter)


def is_cl_file(path: str | Path) -> bool:
    """Whether a file is CL text by its content, whatever its suffix (an NX CLSF listing saved
    as `.txt`): its first SNIFF_BYTES are text, not binary, with CL statements
    (`is_cl_text`). A file that cannot be read is not."""
    try:
        with Path(path).open("rb") as fh:
            head = _decode(fh.read(SNIFF_BYTES))
    except OSError:
        return False
    return _BINARY.search(head.rstrip("\x1a")) is None and is_cl_text(head)
