"""Running `pathcheck` on a hostile part file as a real subprocess, and what every such run must
hold (issue #18): no traceback, no signal, exit code 0, 1 or 2, an exit-2 message of one line
naming the file, no run over 60 s, no process over 2 GB (peak RSS of the run and of every process
it started, measured by `tests/measured.py`)."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from measured import run_measured

PATHCHECK = Path(sys.executable).with_name("pathcheck")
TIME_LIMIT_S = 60.0
MEMORY_LIMIT_MB = 2048.0


@dataclass
class Run:
    """One finished run: exit code (negative: killed by that signal), output, wall time,
    peak RSS in MB over the process tree, and whether the time limit killed it."""

    argv: list[str]
    rc: int
    stdout: str
    stderr: str
    seconds: float
    max_rss_mb: float
    timed_out: bool


def run_pathcheck(args: list[str], timeout: float = TIME_LIMIT_S) -> Run:
    """`pathcheck ARGS` in its own session, killed (the whole group) after `timeout` s."""
    argv = [str(PATHCHECK), *args]
    e = run_measured(argv, timeout)
    return Run(argv, e.code, e.stdout, e.stderr, e.seconds, e.peak_mb, e.timed_out)


def problems(run: Run, path: Path) -> list[str]:
    """What is wrong with a run on the hostile file `path` (empty when it behaved)."""
    bad = []
    if run.timed_out or run.seconds > TIME_LIMIT_S:
        bad.append(f"ran {run.seconds:.1f} s (limit {TIME_LIMIT_S:.0f} s)")
    if run.rc not in (0, 1, 2):
        bad.append(f"exit code {run.rc}")
    if "Traceback" in run.stderr:
        bad.append("traceback: " + run.stderr[-400:])
    if run.max_rss_mb > MEMORY_LIMIT_MB:
        bad.append(f"peak RSS {run.max_rss_mb:.0f} MB")
    if run.rc == 2:
        lines = run.stderr.strip().splitlines()
        if len(lines) != 1 or path.name not in lines[0]:
            bad.append(f"exit 2 without one line naming the file: {run.stderr[-300:]!r}")
    return bad
