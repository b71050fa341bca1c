"""Which CL dialect a text is: Siemens NX CLSF or APT-CL (ISO 4343 style), from its words."""

from __future__ import annotations

import re
from typing import Literal

from checker.errors import PathcheckError

_CLSF = re.compile(r"^[ \t]*(?:TOOL PATH/|TLDATA/|MSYS/|END-OF-PATH\b)", re.M)
_APT = re.compile(
    r"^[ \t]*(?:PARTNO|UNITS?|CUTTER|LOADTL|LOAD|GOTO|GODLTA|FROM|MULTAX|TLAXIS|CSYS|FEDRAT|"
    r"RAPID|CIRCLE|SPINDL|COOLNT|PPRINT|INSERT|CYCLE|CUTCOM|FINI)\b",
    re.M | re.I,
)
_FIRST = re.compile(r"^[^\S\n]*\S[^\n]*", re.M)  # the first non-blank line
_MOTION = re.compile(r"^[ \t]*GOTO[ \t]*/[ \t]*[-+.\d]", re.M | re.I)

Dialect = Literal["apt", "clsf"]


class DialectScan:
    """`detect_dialect` over a text given in pieces of whole lines (`feed`), for files read in
    blocks."""

    def __init__(self) -> None:
        self.clsf = False
        self.apt = False
        self.first = ""

    def feed(self, text: str, end: int | None = None) -> None:
        """Scan ``text[:end]``, whole lines."""
        end = len(text) if end is None else end
        if not self.first:
            m = _FIRST.search(text, 0, end)
            self.first = m.group().strip() if m else ""
        if not self.clsf:
            self.clsf = _CLSF.search(text, 0, end) is not None
        if not (self.clsf or self.apt):
            self.apt = _APT.search(text, 0, end) is not None

    def result(self, path: str) -> Dialect:
        """The dialect of the text fed, or the PathcheckError of `detect_dialect`."""
        if self.clsf:
            return "clsf"
        if self.apt:
            return "apt"
        first = self.first
        shown = first if len(first) <= 40 else first[:40] + "..."
        raise PathcheckError(
            "unknown dialect: expected APT-CL (PARTNO, CUTTER, GOTO, ...) or NX CLSF "
            f"(TOOL PATH/, TLDATA/, GOTO/, ...), found no such statement; first line {shown!r}",
            path=path,
            line=1,
            code="dialect",
        )


def detect_dialect(text: str, *, path: str) -> Dialect:
    """``"clsf"`` when the text has NX statements (``TOOL PATH/``, ``TLDATA/``, ``MSYS/``,
    ``END-OF-PATH``), ``"apt"`` when it has APT-CL major words, else a PathcheckError."""
    scan = DialectScan()
    scan.feed(text)
    return scan.result(path)


def is_cl_text(text: str) -> bool:
    """Whether `text` (e.g. the head of a file) is a CL program: it has an NX CLSF statement,
    or a line that is an APT-CL motion (`GOTO/` and a number). Stricter than
    `detect_dialect`, to tell CL files from other text: notes that quote a `CUTTER/` line, or
    prose with a line that starts "From", are not CL."""
    return _CLSF.search(text) is not None or _MOTION.search(text) is not None
