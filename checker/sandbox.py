"""Native code that can crash or hang on a damaged file (OpenCASCADE's STEP and IGES readers)
runs here: in a child Python process under a time limit (wall clock, killed by the parent; CPU
time as a backstop) and a memory limit (address space, `resource.setrlimit` in the child; the
files it writes no larger), with no core file. The child returns numpy arrays through an `.npz`
in a private temporary folder (no pickle). A crash, a hang or a memory blow-up of the child is
one `PathcheckError` naming the file (code "part"); the parent process never runs the native
code itself. The modules a target names in its `preload` attribute are imported before the
limits are set (the limit counts the whole address space, libraries included, but a library
that cannot be mapped is not the file's fault).

    arrays = run_contained("checker.geometry.occ_io:read_occ_arrays", [str(path), "step"],
                           Limits(seconds=40.0, memory_mb=2048), path, "STEP reader")
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import math
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from importlib import import_module
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError

_PACKAGE_ROOT = str(Path(__file__).resolve().parent.parent)
_ERROR_EXIT = 3  # the child raised PathcheckError (details in the error file)
_MEMORY_EXIT = 4  # the child raised MemoryError
_FAILED_EXIT = 5  # the child raised another exception (details in the error file)
_STDERR_TAIL = 4096  # bytes of the child's stderr kept for the message


@dataclass(frozen=True)
class Limits:
    """`seconds` of wall-clock time and `memory_mb` MB of address space for one child."""

    seconds: float
    memory_mb: int


def run_contained(target: str, args: list[str], limits: Limits, path: str | Path,
                  what: str) -> dict[str, np.ndarray]:
    """Call `target` ("module:function", returning a dict of numpy arrays) with the string
    `args` in a child process under `limits`; its arrays, or PathcheckError naming `path`
    when it fails, crashes, runs out of time or memory. `what` names the native code."""
    tmp = Path(tempfile.mkdtemp(prefix="pathcheck-sandbox-"))
    out, err_file, log = tmp / "result.npz", tmp / "error.json", tmp / "stderr.txt"
    cmd = [sys.executable, "-m", "checker.sandbox", target, str(out), str(err_file),
           f"{limits.seconds:.3f}", str(int(limits.memory_mb)), *args]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [_PACKAGE_ROOT, *filter(None, [os.environ.get("PYTHONPATH")])])}
    try:
        with log.open("wb") as stderr:
            try:
                proc = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                      stderr=stderr, env=env, timeout=limits.seconds,
                                      check=False)
            except subprocess.TimeoutExpired as exc:
                raise PathcheckError(
                    f"{what} stopped after {limits.seconds:.3g} s (the time limit for this "
                    "file; geometry.reader_time_s and reader_time_s_per_mb in the config)",
                    path=path, code="part") from exc
        if proc.returncode == 0:
            with np.load(out, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        raise _failure(proc.returncode, err_file, _tail(log), limits, path, what)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _tail(log: Path) -> str:
    with log.open("rb") as fh:
        fh.seek(max(0, log.stat().st_size - _STDERR_TAIL))
        return fh.read().decode("utf-8", "replace")


def _failure(rc: int, err_file: Path, stderr: str, limits: Limits, path: str | Path,
             what: str) -> PathcheckError:
    """The one-line error for a child that ended with code `rc`."""
    if rc in (_ERROR_EXIT, _FAILED_EXIT) and err_file.exists():
        info = json.loads(err_file.read_text())
        message = info["message"] if rc == _ERROR_EXIT else f"{what} failed: {info['message']}"
        return PathcheckError(message, path=path, line=info.get("line"),
                              code=info.get("code", "part"))
    if rc == _MEMORY_EXIT or "bad_alloc" in stderr or "MemoryError" in stderr:
        return PathcheckError(
            f"{what} needed more than {limits.memory_mb} MB (the memory limit; "
            "geometry.reader_memory_mb in the config)", path=path, code="part")
    if rc < 0 and -rc in (signal.SIGXCPU, signal.SIGKILL):
        return PathcheckError(
            f"{what} stopped after {limits.seconds:.3g} s of CPU time (the time limit for this "
            "file)", path=path, code="part")
    if rc < 0:
        name = signal.Signals(-rc).name if -rc in signal.valid_signals() else str(-rc)
        return PathcheckError(f"{what} crashed on this file ({name}): the file is damaged or "
                              "not supported", path=path, code="part")
    return PathcheckError(f"{what} failed on this file (exit code {rc})", path=path,
                          code="part")


def _limit(which: int, soft: int, extra: int) -> None:
    """Soft limit `soft`, hard limit `soft + extra`, within the hard limit inherited (a worker
    may run under a lower one already)."""
    _, hard = resource.getrlimit(which)
    top = soft + extra if hard == resource.RLIM_INFINITY else min(soft + extra, hard)
    resource.setrlimit(which, (min(soft, top), top))


def _die_with_parent() -> None:
    """SIGKILL this child when its parent dies (Linux prctl PR_SET_PDEATHSIG)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)
    if os.getppid() == 1:  # the parent died before the call above
        os._exit(_FAILED_EXIT)


def _child(argv: list[str]) -> int:
    """The child: set the limits, call the target, write its arrays or its error."""
    target, out, err_file, seconds, memory_mb, *args = argv
    module, name = target.split(":")
    function = getattr(import_module(module), name)
    for lib in getattr(function, "preload", ()):  # libraries loaded before the limits
        import_module(lib)
    _die_with_parent()
    _limit(resource.RLIMIT_AS, int(memory_mb) * 2**20, 0)
    _limit(resource.RLIMIT_CORE, 0, 0)
    _limit(resource.RLIMIT_FSIZE, int(memory_mb) * 2**20, 0)  # its stderr and its result
    _limit(resource.RLIMIT_CPU, math.ceil(float(seconds)) + 1, 1)
    try:
        arrays = function(*args)
    except PathcheckError as err:
        Path(err_file).write_text(json.dumps(
            {"message": err.message, "line": err.line, "code": err.code}))
        return _ERROR_EXIT
    except MemoryError:
        return _MEMORY_EXIT
    except Exception as err:  # a native library's own exception types
        if "OutOfMemory" in type(err).__name__:  # OpenCASCADE's Standard_OutOfMemory
            return _MEMORY_EXIT
        Path(err_file).write_text(json.dumps(
            {"message": f"{type(err).__name__}: {str(err)[:200]}", "code": "part"}))
        return _FAILED_EXIT
    np.savez(out, **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(_child(sys.argv[1:]))
