"""The compressor job (4-axis, ball D12) as a person sees it: on a terminal (a real pty, 120
columns) the progress bar of the best-B search is drawn and moves; with
--quiet it is not; piped, stdout has the summary with no line cut at 80 columns and stderr
has nothing. Real processes (the console entry point), no timing."""

from __future__ import annotations

import errno
import fcntl
import os
import pty
import re
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
JOB = REPO / "samples" / "compressor" / "compressor_small_d12.apt"
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]|\x1b\][^\x07]*\x07")
# a row of rich's progress display part way: the step, its bar, a percentage in 1..99
BAR_ROW = re.compile(r"best B: refinement\s+[━╺╸ ]*━[━╺╸ ]*\s+([1-9]\d?)%")


def _env(tmp_path: Path) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(REPO), PATHCHECK_STORE=str(tmp_path / "r.sqlite"),
               PATHCHECK_LOG_DIR=str(tmp_path / "logs"), TERM="xterm-256color")
    for name in ("COLUMNS", "LINES", "NO_COLOR", "FORCE_COLOR", "TTY_COMPATIBLE",
                 "TTY_INTERACTIVE"):
        env.pop(name, None)
    return env


def _on_pty(args: list[str], tmp_path: Path) -> tuple[int, str]:
    """`pathcheck ARGS` with stdin, stdout and stderr on one pty of 120 x 40: (exit code, all
    it wrote, escape sequences removed)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "checker.cli", *args], cwd=tmp_path,
                            env=_env(tmp_path), stdin=slave, stdout=slave, stderr=slave,
                            close_fds=True)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError as err:  # EIO: the child closed its end
            if err.errno != errno.EIO:
                raise
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    code = proc.wait(timeout=600)
    return code, ANSI.sub("", b"".join(chunks).decode("utf-8", "replace"))


@pytest.mark.slow
def test_the_progress_bar_is_drawn_on_a_terminal_and_not_with_quiet(tmp_path):
    code, screen = _on_pty([str(JOB), "--no-store"], tmp_path)
    assert code == 1, screen[-2000:]  # the D12 job has findings
    assert len({m.group(1) for m in BAR_ROW.finditer(screen)}) >= 3, screen[:3000]  # it moved
    assert re.search(r"FINDINGS: ok \d+  within tolerance \d+  gouge 62", screen)  # the summary
    code, screen = _on_pty([str(JOB), "--no-store", "--quiet"], tmp_path)
    assert code == 1
    assert not re.search(r"\d%", screen), screen[:3000]
    assert "best B" not in screen and re.search(r"FINDINGS: ok \d+ .* gouge 62", screen)


@pytest.mark.slow
def test_piped_there_is_no_progress_and_no_line_cut_at_80_columns(tmp_path):
    run = subprocess.run([sys.executable, "-m", "checker.cli", str(JOB), "--no-store"],
                         cwd=tmp_path, env=_env(tmp_path), capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 1, run.stderr
    assert run.stderr == ""
    assert "\x1b" not in run.stdout and "%" not in run.stdout
    lines = run.stdout.splitlines()
    # the job line is one line, however long (it is about 150 characters)
    head = lines[0]
    assert head.startswith(f"{JOB}: 96 poses, 95 moves") and head.endswith(" s"), head
    assert len(head) > 80 and "part deviation" in head
    for line in lines:  # no counts line was split: each ends with its last count
        if line.startswith(("FINDINGS:", "at the CAM's own angles:")):
            assert re.search(r"inaccessible \d+$", line), line
    assert any(line.startswith("rotary motion:") and line.endswith("with no feasible B")
               for line in lines)
