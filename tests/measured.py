"""Running a command as a real process and measuring how it ended: exit code (negative: the
signal that killed it), wall time, its own peak memory, and whether a time limit killed it.

Linux carries a process's peak RSS across exec, and a child that Python starts by vfork + exec
inherits the peak of the parent it shares memory with until the exec: a `pathcheck` started
from a test process that has grown to 1.3 GB would report 1.3 GB. So the command is forked from
a small launcher, which waits for it, writes the command's own `ru_maxrss` (KB) to a file, and
ends as the command ended (the same exit code, or the same signal)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

_LAUNCHER = """
import os, signal, sys
pid = os.fork()
if pid == 0:
    os.execvp(sys.argv[2], sys.argv[2:])
_, status, usage = os.wait4(pid, 0)
with open(sys.argv[1], "w") as f:
    f.write(str(usage.ru_maxrss))
if os.WIFSIGNALED(status):
    signal.signal(os.WTERMSIG(status), signal.SIG_DFL)
    os.kill(os.getpid(), os.WTERMSIG(status))
sys.exit(os.waitstatus_to_exitcode(status))
"""


@dataclass(frozen=True)
class Ended:
    """How a command ended: `code` (negative: killed by that signal), its output, wall
    seconds, peak resident memory in MB, whether `timeout` killed it."""

    code: int
    stdout: str
    stderr: str
    seconds: float
    peak_mb: float
    timed_out: bool


def run_measured(argv: list[str], timeout: float, **popen) -> Ended:
    """`argv` in its own session through the launcher, the whole group killed after `timeout`
    s; `popen`: more `subprocess.Popen` arguments (cwd, env, preexec_fn)."""
    killed = threading.Event()

    def kill(pid: int) -> None:
        killed.set()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pid, signal.SIGKILL)

    with (tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err,
          tempfile.TemporaryDirectory() as tmp):
        rss = Path(tmp) / "rss"
        t0 = time.monotonic()
        proc = subprocess.Popen([sys.executable, "-c", _LAUNCHER, str(rss), *map(str, argv)],
                                stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                start_new_session=True, **popen)
        timer = threading.Timer(timeout, kill, (proc.pid,))
        timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        finally:
            timer.cancel()
        seconds = time.monotonic() - t0
        try:
            peak = float(rss.read_text()) / 1024.0
        except (OSError, ValueError):  # the launcher was killed before it wrote it
            peak = usage.ru_maxrss / 1024.0
        out.seek(0)
        err.seek(0)
        return Ended(os.waitstatus_to_exitcode(status), out.read().decode("utf-8", "replace"),
                     err.read().decode("utf-8", "replace"), seconds, peak, killed.is_set())
