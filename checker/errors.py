"""The one error type for bad input: it names the file, the line and what was expected."""

from __future__ import annotations

from pathlib import Path


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
            where = f"{self.path}:{self.line}: " if self.line is not None else f"{self.path}: "
        elif self.line is not None:
            where = f"line {self.line}: "
        return f"{where}{self.message}"

    def to_dict(self) -> dict:
        """Structured form used by the service's error replies."""
        out: dict = {"code": self.code, "message": str(self)}
        if self.line is not None:
            out["line"] = self.line
        return out
