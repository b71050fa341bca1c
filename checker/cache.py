"""Where compiled kernels are cached: `$PATHCHECK_CACHE_DIR`, else the user's cache folder
(platformdirs: `~/.cache/pathcheck` on Linux), else a folder of this user in the temporary
directory when that one cannot be written. numba keeps its files under `numba/<key>/` there,
`<key>` a hash of the package's sources: numba checks a cached kernel against the text of its
own file only, so a kernel that calls a kernel of another file kept that one's old code after
the other file changed (an upgrade, a checkout), until this key. Inside it each kernel lies at
its file's place in the package (kernel_locator.py), so every install of the same sources
shares the folder. A numba cache folder set by the user (`NUMBA_CACHE_DIR`) wins, as it is."""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

CACHE_ENV = "PATHCHECK_CACHE_DIR"
LOCATORS_ENV = "NUMBA_CACHE_LOCATOR_CLASSES"
# pathcheck's own kernels by their place in the package (kernel_locator.py), anything else as
# numba does by default
_LOCATORS = ("checker.kernel_locator.PackageLocator,UserProvidedCacheLocator,InTreeCacheLocator,"
             "UserWideCacheLocator,IPythonCacheLocator,ZipCacheLocator")
KEEP_VERSIONS = 4  # kernel folders of the most recent versions of the sources kept


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


PACKAGE = Path(__file__).resolve().parent


def source_key(root: Path = PACKAGE) -> str:
    """12 hex digits of a hash of the Python sources under `root` (their paths and texts; the
    package's ~160 files in about 5 ms)."""
    h = hashlib.sha1()
    for f in sorted(root.rglob("*.py")):
        h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:12]


def kernel_cache_dir() -> Path:
    """The folder numba caches pathcheck's compiled kernels in (one per version of the
    sources)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    return cache_dir() / "numba" / source_key()


def prune_versions(parent: Path, keep: int = KEEP_VERSIONS) -> None:
    """Delete all but the `keep` most recently modified folders in `parent` (the kernels of
    older versions of the sources; a process of such a version compiles afresh)."""
    try:
        folders = sorted((f for f in parent.iterdir() if f.is_dir()),
                         key=lambda f: f.stat().st_mtime, reverse=True)
    except OSError:
        return
    for old in folders[keep:]:
        shutil.rmtree(old, ignore_errors=True)


def use_kernel_cache() -> Path:
    """Point numba's cache at `kernel_cache_dir()` (before numba is imported; inherited by
    child processes), falling back to the temporary directory when it cannot be written, with
    pathcheck's kernels kept by their place in the package (`kernel_locator`, unless the user
    chose numba's locators). A folder made for a new version of the sources prunes the oldest
    versions'."""
    folder = kernel_cache_dir()
    new = not folder.exists()
    if not _writable(folder):
        folder = Path(tempfile.gettempdir()) / f"pathcheck-{os.getuid()}" / "numba" / source_key()
        new = not folder.exists()
        folder.mkdir(parents=True, exist_ok=True)
    if new and not os.environ.get("NUMBA_CACHE_DIR"):
        prune_versions(folder.parent)
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    os.environ.setdefault(LOCATORS_ENV, _LOCATORS)
    if "numba" in sys.modules:  # imported before pathcheck: make it read the folder again
        sys.modules["numba"].core.config.reload_config()
    return folder


@contextmanager
def kernels_compiled() -> Iterator[list[str]]:
    """The names of the kernels numba compiles inside the block (from its compile events), in
    order: none where the cache served everything (the wheel check, tests)."""
    from numba.core import event

    names: list[str] = []

    class _Compiles(event.Listener):
        def on_start(self, ev) -> None:
            names.append(ev.data["dispatcher"].py_func.__qualname__)

        def on_end(self, ev) -> None:
            pass

    listener = _Compiles()
    event.register("numba:compile", listener)
    try:
        yield names
    finally:
        event.unregister("numba:compile", listener)
