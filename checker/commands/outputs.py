"""The files a command will write, checked before it does any work: no output may be one of its
inputs or another of its outputs (the same file after following links, hard links included),
and each output's folder must exist or be creatable and take a new file. A refusal is one
PathcheckError naming the output; nothing has been written then."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

from checker.atomic import check_writable, make_parent
from checker.errors import PathcheckError

#: (what the file is to the user, e.g. "-o" or "the job file"; its path, or None: not given)
Named = tuple[str, "Path | None"]


def _identity(path: Path) -> tuple | None:
    """What makes two names the same file: (device, inode) of an existing regular file, the
    absolute path with every link resolved for one not yet there; None for what is not a
    regular file (a device or a pipe, written straight into: `/dev/stdout`, `/dev/null`)."""
    try:
        st = path.stat()
    except FileNotFoundError:
        return ("new", str(path.resolve()))
    except OSError:
        return ("new", str(path.absolute()))
    if not os.path.isfile(path):
        return None
    return ("file", st.st_dev, st.st_ino)


def _given(files: Iterable[Named]) -> list[tuple[str, Path]]:
    return [(name, Path(p)) for name, p in files if p is not None and str(p) != "-"]


def distinct_outputs(outputs: Iterable[Named], inputs: Iterable[Named] = ()) -> None:
    """PathcheckError (code "usage") when an output is an input or another output: the same
    existing file by device and inode (symbolic and hard links followed), or the same new
    file by its resolved path."""
    seen: dict[tuple, str] = {}
    for name, path in _given(inputs):
        key = _identity(path)
        if key is not None:
            seen.setdefault(key, f"{name} {path}")
    for name, path in _given(outputs):
        key = _identity(path)
        if key is None:
            continue
        if key in seen:
            raise PathcheckError(
                f"{name} would overwrite {seen[key]} (the same file): expected an output file "
                "apart from the run's inputs and other outputs; nothing was written",
                path=path, code="usage")
        seen[key] = f"{name} {path}"


def probe_folder(path: Path, what: str) -> None:
    """Create `path`'s folder and make (and remove) a file in it: a folder the system will not
    write to (a read-only mount, `/sys`, no permission even for root) fails here, not after
    the run. A device or pipe target is written straight into and not probed."""
    if path.exists() and not path.is_file():
        return
    make_parent(path, what)
    folder = path.resolve().parent
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".probe", dir=folder)
    except OSError as err:
        raise PathcheckError(f"cannot write {what}: {err.strerror or err} in the folder "
                             f"{folder}", path=path, code="output") from None
    os.close(fd)
    Path(tmp).unlink(missing_ok=True)


def prepare_outputs(outputs: Iterable[tuple[str, Path | None, str]],
                    inputs: Iterable[Named] = ()) -> None:
    """Before any work: `outputs` (option name, path or None, what it is, e.g. "G-code") apart
    from each other and from `inputs`, each writable (`checker.atomic.check_writable`) in a
    folder that takes a new file (`probe_folder`). `-` (stdout) is not a file."""
    outputs = [(name, p, what) for name, p, what in outputs
               if p is not None and str(p) != "-"]
    distinct_outputs([(name, p) for name, p, _ in outputs], inputs)
    for _, path, what in outputs:
        check_writable(path, what)
        probe_folder(Path(path), what)
