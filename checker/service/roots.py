"""The folders the service may read (`pathcheck serve --root DIR`, default the working
directory): every path in a request is resolved (symlinks followed, relative paths taken from
the first root) and must lie inside a root and be a regular file; anything else is refused
with a structured error that says nothing about what lies outside the roots."""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Iterable
from pathlib import Path

from checker.errors import PathcheckError

_KINDS = {stat.S_IFDIR: "a directory", stat.S_IFCHR: "a character device",
          stat.S_IFBLK: "a block device", stat.S_IFIFO: "a FIFO", stat.S_IFSOCK: "a socket"}


class Roots:
    """Resolved root folders; `file()` is the one gate every request path goes through."""

    def __init__(self, folders: Iterable[str | Path]) -> None:
        resolved = []
        for folder in folders:
            path = Path(folder).expanduser().resolve()
            if not path.is_dir():
                raise PathcheckError("expected a folder for --root, found "
                                     f"{'nothing' if not path.exists() else 'a file'}",
                                     path=folder, code="usage")
            resolved.append(path)
        self.folders: tuple[Path, ...] = tuple(resolved) or (Path.cwd().resolve(),)

    def inside(self, path: str | Path) -> Path:
        """`path` resolved (relative to the first root, symlinks followed); PathcheckError
        (code `forbidden`) when it lies outside every root."""
        if "\x00" in str(path):
            raise PathcheckError("expected a file path, found a NUL character", code="request")
        raw = Path(path)
        try:
            full = (raw if raw.is_absolute() else self.folders[0] / raw).resolve()
        except (OSError, RuntimeError):
            raise PathcheckError("expected a path that resolves, found a symlink loop or a "
                                 "folder that cannot be read", path=path, code="input") from None
        if not any(full.is_relative_to(root) for root in self.folders):
            raise _forbidden(path)
        return full

    def file(self, path: str, field: str, what: str, code: str) -> Path:
        """A regular file inside the roots: its resolved path. Outside: `forbidden`; missing or
        not a regular file (directory, device such as /dev/zero, FIFO): `code`, naming what
        was found."""
        full = self.inside(path)
        try:
            mode = os.stat(full).st_mode
        except OSError:
            raise PathcheckError(f"field '{field}': expected {what}, found nothing",
                                 path=path, code=code) from None
        if not stat.S_ISREG(mode):
            found = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
            raise PathcheckError(f"field '{field}': expected {what} (a regular file), found "
                                 f"{found}", path=path, code=code)
        return full

    def args(self) -> list[str]:
        """Command-line arguments that give a worker the same roots."""
        return [arg for root in self.folders for arg in ("--root", str(root))]


def _forbidden(path: str | Path) -> PathcheckError:
    return PathcheckError(
        "outside the service's roots: expected a path under a folder given to `pathcheck "
        "serve --root` (relative paths are taken from the first root)", path=path,
        code="forbidden")


_QUOTED = re.compile(r"""'(?:[^'\\\n]|\\.)*'|"(?:[^"\\\n]|\\.)*\"""")


def redact(err: PathcheckError, path: str) -> PathcheckError:
    """`err` (about the file `path` given by the client) with every quoted span that is not
    part of `path` replaced by `'...'`: the error names the file, the line and what was
    expected, but never shows the file's contents to the client."""
    def keep_or_hide(match: re.Match) -> str:
        return match.group(0) if match.group(0)[1:-1] in path else "'...'"

    message = _QUOTED.sub(keep_or_hide, err.message)
    if message == err.message:
        return err
    return PathcheckError(message, path=err.path, line=err.line, code=err.code)
