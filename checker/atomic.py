"""Every file the tool writes (G-code, JSON, CSV, HTML, PNG, APT) is written whole or not at
all: into a temporary file beside the target, flushed to disk, given the permissions the
user's umask allows (0666 & ~umask, like any file a program creates), then renamed over the
target. On any failure, an interrupt included, the temporary file is removed and an existing
target is left as it was. A failure (full disk, permission, missing folder) is one
PathcheckError naming the file.

A target that is not a regular file (`/dev/stdout`, `/dev/full`, a pipe) is written straight
into, never renamed over (that would replace a device node with a file); a symbolic link is
followed, and the file it points to is replaced, not the link."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from checker.errors import PathcheckError


def current_umask() -> int:
    """The process's umask, read without changing it where the system tells it (Linux
    /proc), else by setting and restoring it."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_file(path: str | Path, data: str | bytes, *, what: str,
               encoding: str = "utf-8") -> Path:
    """Write `data` (text in `encoding`, or bytes) to `path` atomically; `what` names the
    file's kind in the one-line error ("G-code", "results JSON", ...)."""
    given = path = Path(path)
    payload = data.encode(encoding) if isinstance(data, str) else data
    if path.is_symlink():
        path = path.resolve()
    if path.exists() and not path.is_file():
        return _write_special(path, payload, what, given)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp",
                                   dir=path.parent if str(path.parent) else ".")
    except OSError as err:
        raise PathcheckError(f"cannot write {what}: {err.strerror or err}", path=given,
                             code="output") from err
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(payload)
            fh.flush()
            os.fsync(fh.fileno())
            os.fchmod(fh.fileno(), 0o666 & ~current_umask())
        os.replace(tmp, path)
    except BaseException as err:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise PathcheckError(f"cannot write {what}: {err.strerror or err}", path=given,
                                 code="output") from err
        raise
    return path


def _write_special(path: Path, payload: bytes, what: str, given: Path) -> Path:
    """Write into an existing device, pipe or other non-regular file (no rename)."""
    try:
        with open(path, "wb", buffering=0) as fh:
            view = memoryview(payload)
            while view:
                view = view[fh.write(view):]
    except OSError as err:
        raise PathcheckError(f"cannot write {what}: {err.strerror or err}", path=given,
                             code="output") from err
    return path


def make_parent(path: str | Path, what: str) -> None:
    """Create the folder `path` will be written in; PathcheckError naming it if it cannot be."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise PathcheckError(f"cannot create the folder for the {what}: "
                             f"{err.strerror or err}", path=path, code="output") from err


def check_writable(path: str | Path, what: str) -> None:
    """Fail before a long run when `path` cannot be written: a folder, or a parent folder that
    exists but cannot be written to (missing folders are created when writing)."""
    path = Path(path)
    if path.is_dir():
        raise PathcheckError(f"cannot write {what}: expected a file name, found a folder",
                             path=path, code="output")
    folder = path.resolve().parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if path.exists() and not path.is_file():
        return  # a device or a pipe: written straight into
    if not folder.is_dir():
        raise PathcheckError(f"cannot write {what}: {folder} is a file, expected a folder",
                             path=path, code="output")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise PathcheckError(f"cannot write {what}: the folder {folder} is not writable",
                             path=path, code="output")
