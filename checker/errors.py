"""The one error type for bad input: it names the file, the line and what was expected."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

# control characters and the line breaks of Unicode, as escapes: a file name holding a newline
# stays on its error's one line
_ESCAPES = {**{c: f"\\x{c:02x}" for c in (*range(32), 127, 0x85)},
            ord("\n"): "\\n", ord("\r"): "\\r", ord("\t"): "\\t",
            0x2028: "\\u2028", 0x2029: "\\u2029"}


def printable(text: str) -> str:
    """`text` with control characters and line breaks escaped (`a\\nb`), for one line."""
    return text.translate(_ESCAPES)


class PathcheckError(Exception):
    """Bad input or usage. The CLI prints ``str(err)`` on one line and exits with code 2; the
    service replies ``{ok: false, error: {code, message, line}}``.

    ``code`` is a short machine-readable tag (``"parse"``, ``"cutter"``, ``"part"``, ...).
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | Path | None = None,
        line: int | None = None,
        code: str = "input",
    ) -> None:
        self.message = " ".join(str(message).split())
        self.path = str(path) if path is not None else None
        self.line = line
        self.code = code
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ""
        if self.path is not None:
            path = printable(self.path)
            where = f"{path}:{self.line}: " if self.line is not None else f"{path}: "
        elif self.line is not None:
            where = f"line {self.line}: "
        return f"{where}{self.message}"

    def to_dict(self) -> dict:
        """Structured form used by the service's error replies."""
        out: dict = {"code": self.code, "message": str(self)}
        if self.line is not None:
            out["line"] = self.line
        return out


def raise_at_first(bad, lines, message: Callable[[int], str], *, path: str | Path | None = None,
                   code: str = "input") -> None:
    """Raise at the first row where `bad (N,) bool` holds, naming its line `lines[k]` (None: no
    line): `message(k)` the text for row k. Nothing when no row is bad."""
    rows = np.flatnonzero(np.asarray(bad, bool))
    if rows.size:
        k = int(rows[0])
        raise PathcheckError(message(k), path=path, code=code,
                             line=None if lines is None else int(lines[k]))


def read_input(path: str | Path, what: str, code: str = "input") -> bytes:
    """The bytes of the input file `path`; a file that cannot be read is one error naming it and
    `what` it is (e.g. "CL file")."""
    try:
        return Path(path).read_bytes()
    except OSError as err:
        raise PathcheckError(f"cannot read {what}: {err.strerror or err}", path=path,
                             code=code) from None
