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
_MOTION = re.compile(r"^[ \t]*GOTO[ \t]*/[ \t]*[-+.\d]", re.M | re.I)

Dialect = Literal["apt", "clsf"]


def detect_dialect(text: str, *, path: str) -> Dialect:
    """``"clsf"`` when the text has NX statements (``TOOL PATH/``, ``TLDATA/``, ``MSYS/``,
    ``END-OF-PATH``), ``"apt"`` when it has APT-CL major words, else a PathcheckError."""
    if _CLSF.search(text):
        return "clsf"
    if _APT.search(text):
        return "apt"
    first = next((s.strip() for s in text.split("\n") if s.strip()), "")
    shown = first if len(first) <= 40 else first[:40] + "..."
    raise PathcheckError(
        "unknown dialect: expected APT-CL (PARTNO, CUTTER, GOTO, ...) or NX CLSF "
        f"(TOOL PATH/, TLDATA/, GOTO/, ...), found no such statement; first line {shown!r}",
        path=path,
        line=1,
        code="dialect",
    )


def is_cl_text(text: str) -> bool:
    """Whether `text` (e.g. the head of a file) is a CL program: it has an NX CLSF statement,
    or a line that is an APT-CL motion (`GOTO/` and a number). Stricter than
    `detect_dialect`, to tell CL files from other text: notes that quote a `CUTTER/` line, or
    prose with a line that starts "From", are not CL."""
    return _CLSF.search(text) is not None or _MOTION.search(text) is not None
