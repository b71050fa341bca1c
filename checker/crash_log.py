"""Where an internal error (a bug in pathcheck) leaves its traceback for the report:
`$PATHCHECK_LOG_DIR`, else the user's log folder (platformdirs: `~/.local/state/pathcheck/log`
on Linux), else a folder of this user in the temporary directory when that one cannot be
written. One file per crash, named by the time and the process id."""

from __future__ import annotations

import os
import platform
import sys
import tempfile
import time
import traceback
from pathlib import Path

LOG_ENV = "PATHCHECK_LOG_DIR"


def log_dir() -> Path:
    """The folder internal-error logs go to (not created)."""
    if os.environ.get(LOG_ENV):
        return Path(os.environ[LOG_ENV]).expanduser()
    from platformdirs import user_log_dir

    return Path(user_log_dir("pathcheck", appauthor=False))


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("pathcheck")
    except Exception:  # not installed as a package: the log still helps
        return "unknown"


def write_crash_log(err: BaseException, argv: list[str]) -> Path | None:
    """Write the traceback of `err` with the command line, pathcheck's and Python's versions;
    the file's path, or None when no folder could be written."""
    now = time.gmtime()
    stamp = time.strftime("%Y%m%d-%H%M%S", now)
    text = (
        f"pathcheck {_version()} internal error, {time.strftime('%Y-%m-%d %H:%M:%S', now)} UTC\n"
        f"command: pathcheck {' '.join(argv)}\n"
        f"python {sys.version.split()[0]} on {platform.platform()}\n\n"
        + "".join(traceback.format_exception(err))
    )
    fallback = Path(tempfile.gettempdir()) / f"pathcheck-{os.getuid()}" / "log"
    for folder in (log_dir(), fallback):
        path = folder / f"internal-{stamp}-{os.getpid()}.log"
        try:
            folder.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
        except OSError:
            continue
        return path
    return None
