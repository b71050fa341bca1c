"""Every file the tool writes (G-code, JSON, CSV, HTML, PNG, APT) is written whole or not at
all: into a temporary file beside the target, flushed to disk, given the permissions the
user's umask allows (0666 & ~umask, like any file a program creates), then renamed over the
target. On any failure, an interrupt included, the temporary file is removed and an existing
target is left as it was."""

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
    path = Path(path)
    payload = data.encode(encoding) if isinstance(data, str) else data
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp",
                                   dir=path.parent if str(path.parent) else ".")
    except OSError as err:
        raise PathcheckError(f"cannot write {what}: {err.strerror or err}", path=path,
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
            raise PathcheckError(f"cannot write {what}: {err.strerror or err}", path=path,
                                 code="output") from err
        raise
    return path
