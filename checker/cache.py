"""Where compiled kernels are cached: `$PATHCHECK_CACHE_DIR`, else the user's cache folder
(platformdirs: `~/.cache/pathcheck` on Linux), else a folder of this user in the temporary
directory when that one cannot be written. numba keeps its files under `numba/` there, one set
per source file and machine; a numba cache folder set by the user (`NUMBA_CACHE_DIR`) wins."""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

CACHE_ENV = "PATHCHECK_CACHE_DIR"


def cache_dir() -> Path:
    """The pathcheck cache folder (not created)."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV]).expanduser()
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("pathcheck", appauthor=False))


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(folder, os.W_OK | os.X_OK)


def kernel_cache_dir() -> Path:
    """The folder numba caches pathcheck's compiled kernels in."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    return cache_dir() / "numba"


def use_kernel_cache() -> Path:
    """Point numba's cache at `kernel_cache_dir()` (before numba is imported; inherited by
    child processes), falling back to the temporary directory when it cannot be written."""
    folder = kernel_cache_dir()
    if not _writable(folder):
        folder = Path(tempfile.gettempdir()) / f"pathcheck-{os.getuid()}" / "numba"
        folder.mkdir(parents=True, exist_ok=True)
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:  # imported before pathcheck: make it read the folder again
        sys.modules["numba"].core.config.reload_config()
    return folder
