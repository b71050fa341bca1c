"""Starting a command whose own peak memory the test measures. Linux carries a process's peak
RSS across exec, and a child that Python starts by vfork + exec inherits the peak of the parent
it shares memory with until the exec: a `pathcheck` started from a test process that has grown
to 1.3 GB would report 1.3 GB. So the command is forked from a small launcher, which waits for
it and writes the command's own `ru_maxrss` (KB) to a file, and ends as the command ended (the
same exit code, or the same signal)."""

from __future__ import annotations

import sys
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


def launched(argv: list[str], rss_file: Path) -> list[str]:
    """`argv` run through the launcher, which writes its peak RSS to `rss_file`."""
    return [sys.executable, "-c", _LAUNCHER, str(rss_file), *map(str, argv)]


def peak_mb(rss_file: Path, fallback_kb: float) -> float:
    """The command's peak RSS (MB) from `rss_file`, else `fallback_kb` (the launcher was
    killed before it could write it)."""
    try:
        return float(rss_file.read_text()) / 1024.0
    except (OSError, ValueError):
        return fallback_kb / 1024.0
