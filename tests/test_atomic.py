"""Files the tool writes are whole or absent, with the permissions of the user's umask: the
writer on its own (failure, interrupt, SIGTERM mid-write) and `pathcheck JOB -o --json` as a
real process."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import textwrap

import pytest
from wall_jobs import wall_pass, write_wall_part

from checker.atomic import current_umask, write_file
from checker.errors import PathcheckError


def _mode(path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


@pytest.fixture
def umask():
    """Set the process umask for one test and restore it."""
    saved = os.umask(0o022)
    yield lambda mask: os.umask(mask)
    os.umask(saved)


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_mode_follows_the_umask(tmp_path, umask, mask, mode):
    umask(mask)
    assert current_umask() == mask
    target = write_file(tmp_path / "job.nc", "G0 X0\n", what="G-code")
    assert _mode(target) == mode and target.read_text() == "G0 X0\n"
    replaced = write_file(target, b"\x89PNG", what="picture")  # over an existing file
    assert _mode(replaced) == mode and replaced.read_bytes() == b"\x89PNG"


def test_failed_write_keeps_the_old_file_and_leaves_nothing(tmp_path, monkeypatch):
    target = tmp_path / "out.json"
    write_file(target, "{}", what="results JSON")

    def full(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", full)
    with pytest.raises(PathcheckError, match="out.json: cannot write results JSON: No space"):
        write_file(target, '{"new": 1}', what="results JSON")
    assert target.read_text() == "{}"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_interrupt_during_the_write_leaves_nothing(tmp_path, monkeypatch):
    target = tmp_path / "report.html"

    def interrupted(fd):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_file(target, "<html>", what="report page")
    assert list(tmp_path.iterdir()) == []


def test_sigterm_mid_write_removes_the_temporary_file(tmp_path):
    """A real process killed with SIGTERM while its data goes to disk (fsync made slow):
    exit 143, the previous file intact, no temporary file left."""
    target = tmp_path / "job.nc"
    target.write_text("OLD\n")
    script = textwrap.dedent("""
        import os, signal, sys, time
        from checker.atomic import write_file
        from checker.cli import _terminated
        signal.signal(signal.SIGTERM, _terminated)
        def slow(fd):
            print("writing", flush=True)
            time.sleep(60)
        os.fsync = slow
        write_file(sys.argv[1], "NEW\\n" * 100000, what="G-code")
    """)
    proc = subprocess.Popen([sys.executable, "-c", script, str(target)], stdout=subprocess.PIPE,
                            text=True)
    assert proc.stdout.readline().strip() == "writing"
    assert len(list(tmp_path.iterdir())) == 2  # the old file and the temporary one
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 128 + signal.SIGTERM
    assert [p.name for p in tmp_path.iterdir()] == ["job.nc"]
    assert target.read_text() == "OLD\n"


def test_cli_outputs_have_the_umask_permissions(repo, tmp_path):
    """`pathcheck JOB -o JOB.nc --json JOB.json` under umask 027: both files 0640 (a small job:
    a ball along a floor into a wall, tests/wall_jobs.py)."""
    write_wall_part(tmp_path / "wall.json")
    job = tmp_path / "wall.apt"
    job.write_text("\n".join(["UNITS/MM", *wall_pass("CUTTER/10,5", 1, 0.0, 5.0), "FINI"]))
    nc, js = tmp_path / "small.nc", tmp_path / "small.json"
    run = subprocess.run(
        [sys.executable, "-m", "checker.cli", str(job),
         "-o", str(nc), "--json", str(js), "--on-findings", "comment"],
        capture_output=True, text=True, timeout=600, preexec_fn=lambda: os.umask(0o027),
        env=dict(os.environ, PATHCHECK_STORE=str(tmp_path / "results.sqlite")))
    assert run.returncode in (0, 1), run.stderr
    assert _mode(nc) == 0o640 and _mode(js) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")) == []
