"""Issue 39's hostile round, each as a real `pathcheck` process (or the service's handler) with
its expected ending: no output may overwrite an input or another output, an output folder that
takes no file and a store that is not a pathcheck store fail before the check, CC points are
validated once for the CLI and the service, LinuxCNC's arc turn count P is read and bounded,
every error is one line (click's usage errors, a newline in a file name, a 1e308 normal, a
program with neither units nor motion) and Ctrl-C is exit 130."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from checker.cli import EXIT_INPUT
from tests.hostile import MOULD, REPO, run_pathcheck, small_job

EXIT_INTERRUPTED = 130  # 128 + SIGINT, as `pathcheck --help` states
# a CC point on the mould's first surface (the hostile programs' own)
ON_MOULD = "-59.5,-32,-0.02,0,0,1"


@pytest.fixture()
def job(tmp_path) -> Path:
    """The small mould job with its part beside it."""
    return small_job(tmp_path)


def _one_line(run, pattern: str) -> None:
    """Exit 2, one line on stderr matching `pattern`, nothing on stdout (no check ran)."""
    assert run.code == EXIT_INPUT, run.why()
    assert "Traceback" not in run.stderr and "Warning" not in run.stderr, run.why()
    lines = [line for line in run.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and re.fullmatch(pattern, lines[0]), run.why()


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


# ---------------------------------------------------------------- outputs that are inputs
@pytest.mark.parametrize("args, named, other", [
    (["small.apt", "-o", "small.apt"], "small.apt", "the job file small.apt"),
    (["small.apt", "-o", "link.apt"], "link.apt", "the job file small.apt"),
    (["small.apt", "-o", "hard.apt"], "hard.apt", "the job file small.apt"),
    (["small.apt", "--json", "small.json"], "small.json", "the part small.json"),
    (["small.apt", "-o", "out.nc", "--json", "sub/../out.nc"], "sub/../out.nc",
     "-o out.nc"),
    (["small.apt", "-o", "results.sqlite"], "results.sqlite",
     "the results store .*results.sqlite"),
    (["info", "small.apt", "--json", "link.apt"], "link.apt", "the file small.apt"),
    (["allowable", "--part", "small.json", "--cc", "cc.csv", "--cutter", "CUTTER/10,5",
      "--json", "cc.csv"], "cc.csv", "--cc cc.csv"),
])
def test_an_output_that_is_an_input_or_another_output_is_refused_and_nothing_written(
        job, tmp_path, args, named, other):
    (tmp_path / "link.apt").symlink_to("small.apt")
    os.link(job, tmp_path / "hard.apt")
    (tmp_path / "sub").mkdir()
    (tmp_path / "cc.csv").write_text(f"x,y,z,nx,ny,nz\n{ON_MOULD}\n")
    with sqlite3.connect(tmp_path / "results.sqlite"):
        pass  # an empty store
    before = _files(tmp_path)
    run = run_pathcheck(args, cwd=tmp_path)
    _one_line(run, rf"pathcheck: {re.escape(named)}: \S+ would overwrite {other} \(the same "
                   r"file\): expected an output file apart from the run's inputs and other "
                   r"outputs; nothing was written")
    assert _files(tmp_path) == before and run.stdout == ""


def test_an_output_folder_that_takes_no_file_fails_before_the_check(job, tmp_path):
    """/sys refuses new files even to root, whose os.access says yes: probed, not asked."""
    try:
        Path("/sys/pathcheck-probe").touch()
    except OSError:
        pass
    else:
        Path("/sys/pathcheck-probe").unlink()
        pytest.skip("/sys takes files here")
    run = run_pathcheck([job.name, "-o", "/sys/x.nc"], cwd=tmp_path)
    assert run.stdout == "", run.why()  # no summary: the check did not run
    assert not (tmp_path / "results.sqlite").exists()
    _one_line(run, r"pathcheck: /sys/x\.nc: cannot write G-code: .*")


# ---------------------------------------------------------------- the results store
def _foreign(path: Path) -> None:
    with sqlite3.connect(path) as con:
        con.execute("CREATE TABLE accounts (name TEXT)")


def _newer(path: Path) -> None:
    with sqlite3.connect(path) as con:
        con.execute("PRAGMA user_version = 999")
        con.execute("CREATE TABLE jobs (id INTEGER)")


def _corrupt(path: Path) -> None:
    path.write_bytes(b"SQLite format 3\x00" + bytes(range(256)) * 16)


@pytest.mark.parametrize("make, says", [
    (_foreign, r"expected a pathcheck results store, found an SQLite file with 1 other tables"),
    (_newer, r"store schema version 999 is newer than this pathcheck understands"),
    (_corrupt, r"expected an SQLite pathcheck store, found an unreadable file"),
])
@pytest.mark.parametrize("command", [["small.apt"], ["check-gcode", "prog.nc", "--part",
                                                     "small.json", "--cutter", "CUTTER/10,5"]])
def test_a_check_into_a_store_that_is_not_ours_is_exit_2_before_the_check(
        job, tmp_path, make, says, command):
    (tmp_path / "prog.nc").write_text("G21 G90 G17\nG0 X-50 Y-30 Z30\nG1 Z20 F100\n")
    store = tmp_path / "results.sqlite"
    make(store)
    before = store.read_bytes()
    run = run_pathcheck(command, cwd=tmp_path)
    _one_line(run, rf"pathcheck: {re.escape(str(store))}: {says}.*")
    assert store.read_bytes() == before and run.stdout == ""


# ---------------------------------------------------------------- CC points, CLI and service
def test_a_1e308_normal_is_read_and_a_zero_one_names_its_file_and_line(tmp_path):
    (tmp_path / "cc.csv").write_text(f"x,y,z,nx,ny,nz\n{ON_MOULD}\n\n"
                                     "-59.5,-32,-0.02,1e308,-1e308,1\n-59.5,-32,-0.02,0,0,0\n")
    run = run_pathcheck(["allowable", "--part", str(MOULD / "mould.json"), "--cc", "cc.csv",
                         "--cutter", "CUTTER/10,5"], cwd=tmp_path)
    _one_line(run, r"pathcheck: cc\.csv:5: expected a finite non-zero normal \(nx, ny, nz\), "
                   r"found \(0, 0, 0\)")


def test_unit_normals_do_not_overflow():
    from checker.cc_points import Rows, unit_normals

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = unit_normals(np.array([[1e308, -1e308, 1.0], [0.0, 3e-300, 4e-300]]), Rows())
    np.testing.assert_allclose(got, [[2**-0.5, -(2**-0.5), 0.0], [0.0, 0.6, 0.8]], atol=1e-15)


@pytest.fixture(scope="module")
def state():
    from checker.config import default_config
    from checker.service.ops import WorkerState
    from checker.service.part_cache import PartCache

    return WorkerState(config=default_config(), cache=PartCache(1 << 30))


@pytest.mark.parametrize("row, says", [
    ([1e308, 0, 0, 0, 0, 1], r"CC point \(1e\+308, 0, 0\) lies 1e\+308 mm outside the part's "
                             r"box: expected points on the part \(within 195\.5\d* mm\)"),
    ([1e6, 0, 0, 0, 0, 1], r"CC point \(1e\+06, 0, 0\) lies 999920 mm outside the part's box: "
                           r"expected points on the part \(within 195\.5\d* mm\)"),
    ([-59.5, -32, -0.02, 0, 0, 0], r"expected a finite non-zero normal \(nx, ny, nz\), found "
                                   r"\(0, 0, 0\)"),
])
def test_the_service_validates_cc_points_as_the_cli_does(state, tmp_path, row, says):
    from checker.service.recorder import NullRecorder
    from checker.service.worker import handle

    first = [float(v) for v in ON_MOULD.split(",")]
    request = {"op": "allowable", "id": 7, "part": {"path": str(MOULD / "mould.json")},
               "cc": [first, row], "cutter": "CUTTER/10,5"}
    reply, _ = handle(json.dumps(request).encode(), state, NullRecorder())
    assert not reply["ok"] and reply["error"]["code"] == "request", reply
    assert re.fullmatch(rf"field 'cc\.1': {says}", reply["error"]["message"]), reply
    (tmp_path / "cc.csv").write_text("x,y,z,nx,ny,nz\n" + "\n".join(
        ",".join(f"{v:g}" for v in r) for r in (first, row)) + "\n")
    run = run_pathcheck(["allowable", "--part", str(MOULD / "mould.json"), "--cc", "cc.csv",
                         "--cutter", "CUTTER/10,5"], cwd=tmp_path)
    _one_line(run, rf"pathcheck: cc\.csv:3: {says}")


def test_snap_leaves_a_point_beyond_the_tree_unmoved():
    from checker.config import default_config
    from checker.engine.api import _snap
    from checker.geometry import load_part
    from checker.geometry.sampling import sample_part

    part = load_part(MOULD / "mould.json")
    tp = sample_part(part, geometry=default_config().geometry)
    cc = np.array([[1e308, 0.0, 0.0]])
    snapped = _snap(tp, part, cc, np.array([[0.0, 0.0, 1.0]]))
    assert snapped.surface.tolist() == [-1] and snapped.cc.tolist() == cc.tolist()


# ---------------------------------------------------------------- LinuxCNC's arc turns P
def _arc_rows(text: str):
    from checker.postproc.machine import load_machine
    from checker.postproc.reader import read_gcode_text
    from checker.postproc.replay import part_motions

    return part_motions(read_gcode_text(text, "linuxcnc"), load_machine("linuxcnc-hmc"))


def test_arc_turn_count_p_makes_p_minus_1_extra_turns():
    """As LinuxCNC's ARC_FEED(..., rotation = +-P, ...): a full circle G3 ... P3 from (10, 0)
    about the origin turns 3 times (6 pi) while Z falls 3 mm at a steady pitch of 1 mm per
    turn; a quarter G2 ... P2 turns 3/4 + 1 turns clockwise."""
    m = _arc_rows("G21 G90 G17\nG0 X10 Y0 Z0\nG3 X10 Y0 Z-3 I-10 J0 P3 F100\n"
                  "G2 X0 Y10 I-10 J0 P2\n")
    origin = m.xyz[m.line == 2][-1] - [10.0, 0.0, 0.0]  # the centre, (0, 0, 0) in the program
    for line, turns in ((3, 3.0), (4, -1.75)):
        pts = np.vstack([m.xyz[m.line < line][-1], m.xyz[m.line == line]]) - origin
        ang = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
        assert ang[-1] - ang[0] == pytest.approx(turns * 2 * np.pi, abs=1e-9)
        np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), 10.0, atol=1e-9)
        if line == 3:  # z linear in the angle: 1 mm per turn
            np.testing.assert_allclose(pts[:, 2], -(ang - ang[0]) / (2 * np.pi), atol=1e-9)


@pytest.mark.parametrize("word, says", [
    ("P1000000", r"arc turn count P1e\+06: expected 1 to 10,000 turns"),
    ("P0", r"arc turn count P0: expected 1 to 10,000 turns"),
    ("P2.5", r"arc turn count P2\.5 is not a whole number: expected P1, P2, \.\.\. \(full turns "
             r"of G2/G3\)"),
])
def test_an_arc_turn_count_out_of_bounds_is_one_line_naming_the_line(tmp_path, word, says):
    (tmp_path / "helix.ngc").write_text(f"G21 G90 G17\nG0 X10 Y0 Z0\nG3 X10 Y0 Z-3 I-10 J0 "
                                        f"{word} F100\nM2\n")
    run = run_pathcheck(["check-gcode", "helix.ngc", "--machine", "linuxcnc-hmc"], cwd=tmp_path)
    _one_line(run, rf"pathcheck: helix\.ngc:3: {says}")


# ---------------------------------------------------------------- messages
def test_click_usage_errors_are_one_line(job, tmp_path):
    _one_line(run_pathcheck([job.name, "-o", str(tmp_path)], cwd=tmp_path),
              rf"pathcheck: Invalid value for '-o' / '--output': File '{re.escape(str(tmp_path))}'"
              r" is a directory; see 'pathcheck check --help'")
    _one_line(run_pathcheck(["info", "--bogus"], cwd=tmp_path),
              r"pathcheck: No such option '--bogus'.*; see 'pathcheck info --help'")


def test_a_newline_in_a_file_name_stays_on_the_error_line(job, tmp_path):
    named = tmp_path / "two\nlines.apt"
    named.write_text("PARTNO/X\nFINI\n")
    _one_line(run_pathcheck(["info", named.name], cwd=tmp_path),
              r"pathcheck: two\\nlines\.apt: no motion: expected .*")


def test_a_program_with_neither_units_nor_motion_is_one_line(tmp_path):
    (tmp_path / "none.nc").write_text("%\nG90\nM30\n%\n")
    _one_line(run_pathcheck(["check-gcode", "none.nc"], cwd=tmp_path),
              r"pathcheck: none\.nc: no motion: expected G0/G1/G2/G3 moves or drilling cycles, "
              r"found none in 2 blocks")


# ---------------------------------------------------------------- Ctrl-C
def test_sigint_during_a_check_is_exit_130_with_nothing_written(tmp_path):
    """SIGINT in the middle of the mould's check (its advice step runs for seconds): exit 130,
    one line, no G-code and no temporary file left."""
    for name in ("mould.apt", "mould.json"):
        shutil.copy(MOULD / name, tmp_path / name)
    env = dict(os.environ, PYTHONPATH=str(REPO), PATHCHECK_STORE=str(tmp_path / "r.sqlite"),
               PATHCHECK_LOG_DIR=str(tmp_path / "logs"))
    proc = subprocess.Popen([sys.executable, "-m", "checker.cli", "mould.apt", "-v", "-o",
                             "mould.nc"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if "plan and check the program" in line:
            proc.send_signal(signal.SIGINT)
            break
    rest = proc.stderr.read()
    code = proc.wait(timeout=120)
    assert code == EXIT_INTERRUPTED, (code, seen, rest)
    assert rest.splitlines()[-1] == "pathcheck: interrupted", rest
    assert "Traceback" not in rest and not (tmp_path / "mould.nc").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_help_states_the_exit_code_of_an_interrupt():
    run = subprocess.run([sys.executable, "-m", "checker.cli", "--help"], capture_output=True,
                         text=True, env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert f"{EXIT_INTERRUPTED} interrupted" in " ".join(run.stdout.split())


def test_an_output_beside_the_job_that_is_not_read_is_written_again(job, tmp_path):
    """Only the files a run reads are inputs: check-gcode reads no part beside the program, so
    its JSON `prog.json` is written on every run; a check with --part reads no `small.json`."""
    (tmp_path / "prog.nc").write_text("G21 G90 G17\nG0 X-50 Y-30 Z30\nG1 Z20 F100\n")
    shutil.copy(MOULD / "mould.json", tmp_path / "mould.json")
    for _ in range(2):
        run = run_pathcheck(["check-gcode", "prog.nc", "--json", "prog.json"], cwd=tmp_path)
        assert run.code == 0 and json.loads((tmp_path / "prog.json").read_text()), run.why()
    run = run_pathcheck([job.name, "--part", "mould.json", "--json", "small.json", "--no-store"],
                        cwd=tmp_path)
    assert run.code in (0, 1) and json.loads((tmp_path / "small.json").read_text())["job"]
