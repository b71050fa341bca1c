"""Running `pathcheck` as a real process on hostile input and judging how it ended: exit code,
stderr, wall time and the peak memory of the command (`tests/measured.py`)."""

from __future__ import annotations

import os
import resource
import signal
import sys
from dataclasses import dataclass
from pathlib import Path

from tests.measured import run_measured

REPO = Path(__file__).resolve().parents[1]
MOULD = REPO / "samples" / "mould"
# the first 40 records of the mould job: a small clean 3-axis path over the mould part
SMALL_JOB = "\n".join(MOULD.joinpath("mould.apt").read_text().splitlines()[:40]) + "\n"


def small_job(folder: Path) -> Path:
    """The small mould job written into `folder` as small.apt, its part beside it."""
    import shutil

    shutil.copy(MOULD / "mould.json", folder / "small.json")
    path = folder / "small.apt"
    path.write_text(SMALL_JOB)
    return path
PATHCHECK = [sys.executable, "-m", "checker.cli"]
LIMIT_S = 60.0  # no run may take longer
LIMIT_RSS_MB = 2048.0  # nor hold more memory


@dataclass(frozen=True)
class Run:
    """How one `pathcheck` process ended: `code` (negative: killed by that signal), its
    output, wall seconds and peak resident memory in MB."""

    args: tuple[str, ...]
    code: int
    stdout: str
    stderr: str
    seconds: float
    rss_mb: float

    def why(self) -> str:
        return (f"pathcheck {' '.join(self.args)} -> exit {self.code} in {self.seconds:.1f} s, "
                f"{self.rss_mb:.0f} MB\nstderr: {self.stderr[-2000:]}")


def _limit_memory() -> None:
    """In the child: an address-space cap well above the RSS limit (numba and its thread pool
    reserve much more than they touch), so that a runaway allocation fails instead of
    swapping the shared machine."""
    cap = 6 * 1024**3
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))


def run_pathcheck(args: list[str], *, cwd: Path, env: dict[str, str] | None = None,
                  timeout: float = LIMIT_S + 30, preexec=_limit_memory) -> Run:
    """`pathcheck ARGS` in a child process (the store and the logs in `cwd`), waited for with
    wait4 so that its own peak RSS (and that of its children) is known; killed after
    `timeout` s."""
    full_env = dict(os.environ, PATHCHECK_STORE=str(cwd / "results.sqlite"),
                    PATHCHECK_LOG_DIR=str(cwd / "logs"), PYTHONPATH=str(REPO))
    full_env.update(env or {})
    e = run_measured([*PATHCHECK, *args], timeout, cwd=cwd, env=full_env, preexec_fn=preexec)
    return Run(tuple(args), e.code, e.stdout, e.stderr, e.seconds, e.peak_mb)


def assert_sane(run: Run, named: str | tuple[str, ...]) -> None:
    """No traceback, no signal, an exit code of 0, 1 or 2, within the time and memory limits,
    and an exit 2 says why in one line naming the file `named` (or one of them)."""
    assert "Traceback" not in run.stderr and "Traceback" not in run.stdout, run.why()
    assert run.code >= 0, f"killed by {signal.Signals(-run.code).name}: " + run.why()
    assert run.code in (0, 1, 2), run.why()
    assert run.seconds < LIMIT_S, run.why()
    assert run.rss_mb < LIMIT_RSS_MB, run.why()
    if run.code == 2:
        lines = [line for line in run.stderr.splitlines() if line.strip()]
        assert len(lines) == 1, run.why()
        names = (named,) if isinstance(named, str) else named
        assert lines[0].startswith(tuple(f"pathcheck: {n}" for n in names)), run.why()
