"""Where compiled kernels are cached: `$PATHCHECK_CACHE_DIR`, else the user's cache folder
(platformdirs: `~/.cache/pathcheck` on Linux), else a folder of this user in the temporary
directory when that one cannot be written. numba keeps its files under `numba/<key>/` there,
`<key>` a hash of the package's sources: numba checks a cached kernel against the text of its
own file only, so a kernel that calls a kernel of another file kept that one's old code after
the other file changed (an upgrade, a checkout), until this key. Inside it each kernel lies at
its file's place in the package (kernel_locator.py), so every install of the same sources
shares the folder. A numba cache folder set by the user (`NUMBA_CACHE_DIR`) wins, as it is.

Portable kernels: a wheel built by `make wheel` ships kernels compiled for LLVM's x86-64-v3 CPU
(`PORTABLE_CPU`: AVX2 and FMA, every x86-64 CPU since about 2013-2015; `resources/kernels/`,
built for its own sources, numba and Python). A new cache folder is seeded with them, and on a
CPU that has those instructions, until `pathcheck warm` has compiled kernels tuned to this CPU
into it (its mark, `HOST_MARK`), every process compiles and loads for that CPU
(`NUMBA_CPU_NAME`, part of numba's cache key, with no extra features), so the first check after
an install loads instead of compiling. `PATHCHECK_KERNELS` (`host` or `portable`) says which,
for a process and the processes it starts."""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from checker.resources import resource

CACHE_ENV = "PATHCHECK_CACHE_DIR"
LOCATORS_ENV = "NUMBA_CACHE_LOCATOR_CLASSES"
# pathcheck's own kernels by their place in the package (kernel_locator.py), anything else as
# numba does by default
_LOCATORS = ("checker.kernel_locator.PackageLocator,UserProvidedCacheLocator,InTreeCacheLocator,"
             "UserWideCacheLocator,IPythonCacheLocator,ZipCacheLocator")
KEEP_VERSIONS = 4  # kernel folders of the most recent versions of the sources kept
KERNELS_ENV = "PATHCHECK_KERNELS"  # "host" (tuned to this CPU) or "portable" (x86-64-v3)
HOST_MARK = "host-kernels"  # in a cache folder: `pathcheck warm` compiled this CPU's kernels
PORTABLE_STAMP = "STAMP"  # in the shipped kernels: the sources, numba and Python they are for
PORTABLE_CPU = "x86-64-v3"  # LLVM's name (AVX2, FMA); numba's "generic" x86-64 is far slower
# what a CPU must have to run x86-64-v3 code (the flags of Linux's /proc/cpuinfo; "abm": lzcnt)
_V3_FLAGS = frozenset(("avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "abm", "movbe", "xsave",
                       "cx16", "lahf_lm", "popcnt", "sse4_1", "sse4_2", "ssse3"))


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


def portable_stamp() -> str:
    """What portable kernels must have been built for to be loaded here: these sources, this
    numba (its cache index holds its version) and this Python (its files name it)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        numba_version = version("numba")
    except PackageNotFoundError:
        numba_version = "?"
    return (f"{source_key()} numba-{numba_version} py{sys.version_info[0]}{sys.version_info[1]} "
            f"{PORTABLE_CPU}")


def runs_portable(cpuinfo: Path = Path("/proc/cpuinfo")) -> bool:
    """Whether this CPU runs `PORTABLE_CPU` code (False where it cannot be told)."""
    try:
        with cpuinfo.open() as f:
            flags = next((line for line in f if line.startswith("flags")), "")
    except OSError:
        return False
    return set(flags.partition(":")[2].split()) >= _V3_FLAGS


def portable_kernels() -> Path | None:
    """The folder of the portable kernels shipped with the package, when they were built for
    `portable_stamp()` (None otherwise: a source checkout, another numba or Python)."""
    shipped = resource("kernels")
    try:
        stamp = (shipped / PORTABLE_STAMP).read_text().strip()
    except OSError:
        return None
    return shipped if stamp == portable_stamp() else None


def _seed(folder: Path) -> None:
    """Fill the new cache `folder` with the shipped portable kernels and their stamp, whole or
    not at all (a copy renamed into place; another process may do the same at once)."""
    shipped = portable_kernels()
    if shipped is None:
        return
    partial = folder.with_name(f".{folder.name}.{os.getpid()}")
    try:
        shutil.copytree(shipped, partial)
        os.rename(partial, folder)
    except OSError:
        shutil.rmtree(partial, ignore_errors=True)


def _choose_kernels(folder: Path) -> None:
    """Compile and load this CPU's kernels, or `PORTABLE_CPU`'s while `folder` holds the
    portable ones (their stamp) and not yet this CPU's (`HOST_MARK`), on a CPU that runs them.
    `KERNELS_ENV` set by a parent process (or by `pathcheck warm`) decides instead; a CPU chosen
    by the user (`NUMBA_CPU_NAME`) stays."""
    chosen = os.environ.get(KERNELS_ENV)
    if chosen is None:
        if os.environ.get("NUMBA_CPU_NAME"):
            return
        portable = ((folder / PORTABLE_STAMP).exists() and not (folder / HOST_MARK).exists()
                    and runs_portable())
        chosen = os.environ[KERNELS_ENV] = "portable" if portable else "host"
    if chosen == "portable":
        os.environ.update(NUMBA_CPU_NAME=PORTABLE_CPU, NUMBA_CPU_FEATURES="")
    elif os.environ.get("NUMBA_CPU_NAME") == PORTABLE_CPU:
        del os.environ["NUMBA_CPU_NAME"]
        os.environ.pop("NUMBA_CPU_FEATURES", None)


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
    versions' and is seeded with the shipped portable kernels; which CPU's kernels the process
    uses: `_choose_kernels`."""
    folder = kernel_cache_dir()
    own = not os.environ.get("NUMBA_CACHE_DIR")
    new = not folder.exists()
    if not _writable(folder.parent) or not (new or _writable(folder)):
        folder = Path(tempfile.gettempdir()) / f"pathcheck-{os.getuid()}" / "numba" / source_key()
        folder.parent.mkdir(parents=True, exist_ok=True)
        new = not folder.exists()
    if new and own:
        _seed(folder)
        prune_versions(folder.parent)
    folder.mkdir(parents=True, exist_ok=True)
    _choose_kernels(folder)
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
