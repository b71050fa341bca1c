"""Issue #18's hostile CL and G-code programs, files and stores, each as a real `pathcheck`
process with its expected one-line error: sizes bounded by the machine, not by the input's
numbers; a file that cannot be written is exit 2 with the check still recorded; a store on a
full disk, a killed batch worker and a damaged store row each cost only themselves; a bug is
exit 3 with its traceback in a log."""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from checker.cli import EXIT_INPUT, EXIT_INTERNAL, main
from checker.store import ResultsStore
from tests.hostile import MOULD, REPO, SMALL_JOB, assert_sane, run_pathcheck, small_job
from tests.synthetic_results import synthetic_document

GCODE_HEAD = "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z0 F100\n"


@pytest.fixture()
def job(tmp_path) -> Path:
    """The small mould job with its part beside it."""
    return small_job(tmp_path)


def _one_line(run, pattern: str) -> None:
    """Exit 2, one line on stderr matching `pattern` (a regular expression)."""
    assert run.code == EXIT_INPUT, run.why()
    assert_sane(run, "")
    assert re.fullmatch(pattern, run.stderr.strip()), run.why()


# ---------------------------------------------------------------- sizes bounded by the machine
def test_a_coordinate_beyond_any_machine_is_an_error_naming_the_line(job, tmp_path):
    lines = SMALL_JOB.splitlines()
    lines[20] = "GOTO/1e15,0,0"
    (tmp_path / "far.apt").write_text("\n".join(lines) + "\n")
    shutil.copy(tmp_path / "small.json", tmp_path / "far.json")
    for args in (["info", "far.apt"], ["far.apt"]):
        _one_line(run_pathcheck(args, cwd=tmp_path),
                  r"pathcheck: far\.apt:21: tool position \(1e\+15, 0, 0\) mm in the part frame "
                  r"is beyond any machine's reach: expected coordinates within \+-100000 mm")


def test_a_100_m_move_stays_small_in_poses_and_memory(job, tmp_path):
    """The move is checked by the bound between poses, not sampled along its 100 m: the poses
    checked stay those of the small job, give or take the halvings near the part."""
    lines = SMALL_JOB.splitlines()
    lines[20] = "GOTO/100000,0,-3"  # 100 m out and back, across the part both ways
    job.write_text("\n".join(lines) + "\n")
    run = run_pathcheck([job.name, "--no-store", "--json", "-"], cwd=tmp_path)
    assert run.code == 1, run.why()  # its path back through the part gouges
    assert_sane(run, job.name)
    summary = json.loads(run.stdout)["summary"]
    assert summary["poses_checked"] < 20 * summary["cl_points"], summary["poses_checked"]
    assert run.rss_mb < 1024, run.why()


def test_an_nx_listing_read_in_inches_by_its_first_feed_stays_small(realdata, tmp_path):
    text = (realdata / "mech491-nx-clsf" / "APT_Zig_Zag_Smoothed.txt").read_text()
    assert "FEDRAT/MMPM" in text
    (tmp_path / "inch.txt").write_text(text.replace("FEDRAT/MMPM", "FEDRAT/IPM", 1))
    shutil.copy(MOULD / "mould.json", tmp_path / "inch.json")
    info = run_pathcheck(["info", "inch.txt", "--json", "-"], cwd=tmp_path)
    assert info.code == 0 and json.loads(info.stdout)["units"] == "inch", info.why()
    run = run_pathcheck(["inch.txt", "--cutter", "CUTTER/10", "--no-store"], cwd=tmp_path)
    assert_sane(run, "inch.txt")  # 25.4 times larger, bounded all the same
    assert run.rss_mb < 1024, run.why()


@pytest.mark.parametrize("arc, expected", [
    ("G2 X0 Y0 I100000000000", r"pathcheck: p\.nc:4: arc centre I reaches 1e\+11 mm, beyond "
                               r"any machine's reach: expected within \+-100000 mm"),
    ("G2 X0 Y0 I1e11", r"pathcheck: p\.nc:4: 'I1e11': exponent notation, which G-code does not "
                       r"have \(a control reads the number, then an E word\): expected a plain "
                       r"decimal number"),
    ("G2 X10 Y0 R#7", r"pathcheck: p\.nc:4: arc word R has no known value \(an unset "
                      r"parameter\?\): expected a number"),
    ("G1 X0 B1000000000", r"pathcheck: p\.nc:4: B reaches 1e\+09 deg, beyond any machine's "
                          r"reach: expected within \+-1e\+06 deg"),
])
def test_hostile_gcode_words(tmp_path, arc, expected):
    (tmp_path / "p.nc").write_text(GCODE_HEAD + arc + "\nM30\n")
    _one_line(run_pathcheck(["check-gcode", "p.nc", "--machine", "fanuc-hmc"], cwd=tmp_path),
              expected)


def test_a_program_expanding_into_too_many_positions_is_refused(tmp_path):
    circles = "G2 X0 Y0 I90000\n" * 800  # 90 m circles: 6,700 chords each, 5.3 M in all
    (tmp_path / "p.nc").write_text(GCODE_HEAD + circles + "M30\n")
    run = run_pathcheck(["check-gcode", "p.nc", "--machine", "fanuc-hmc"], cwd=tmp_path)
    _one_line(run, r"pathcheck: p\.nc:4: the program's arcs and rotary turns expand into "
                   r"5,[0-9,]+ positions \(this block alone 6,[0-9]{3}\), more than 5,000,000: "
                   r"expected arcs and turns a machine makes")
    assert run.rss_mb < 1024, run.why()


# ---------------------------------------------------------------- empty programs, CC rows
def test_programs_without_motion_are_errors_naming_the_file(tmp_path):
    (tmp_path / "none.apt").write_text("PARTNO/NOTHING\nCUTTER/6\nFEDRAT/100\nFINI\n")
    (tmp_path / "none.json").write_text((MOULD / "mould.json").read_text())
    (tmp_path / "none.nc").write_text("%\nG21 G90\nM30\n%\n")
    _one_line(run_pathcheck(["info", "none.apt"], cwd=tmp_path),
              r"pathcheck: none\.apt: no motion: expected GOTO/, FROM/ or GODLTA/ records, "
              r"found none")
    _one_line(run_pathcheck(["none.apt"], cwd=tmp_path),
              r"pathcheck: none\.apt: no cutting moves: .*")
    _one_line(run_pathcheck(["check-gcode", "none.nc"], cwd=tmp_path),
              r"pathcheck: none\.nc: no motion: expected G0/G1/G2/G3 moves or drilling cycles, "
              r"found none in 2 blocks")


@pytest.mark.parametrize("row, expected", [
    ("1_0,0,0,0,0,1", r"pathcheck: cc\.csv:3: expected 6 decimal numbers, found '1_0' in "
                      r"'1_0,0,0,0,0,1'"),
    ("1e308,0,0,0,0,1", r"pathcheck: cc\.csv:3: CC point \(1e\+308, 0, 0\) lies 1e\+308 mm "
                        r"outside the part's box: expected points on the part \(within .* mm\)"),
    ("infinity,0,0,0,0,1", r"pathcheck: cc\.csv:3: expected 6 decimal numbers, found "
                           r"'infinity' .*"),
])
def test_cc_rows_are_validated_before_the_engine(tmp_path, row, expected):
    (tmp_path / "cc.csv").write_text(f"x,y,z,nx,ny,nz\n-59.5,-32,-0.02,0,0,1\n{row}\n")
    run = run_pathcheck(["allowable", "--part", str(MOULD / "mould.json"), "--cc", "cc.csv",
                         "--cutter", "CUTTER/10,5"], cwd=tmp_path)
    _one_line(run, expected)


# ---------------------------------------------------------------- files that cannot be written
def _recorded(tmp_path: Path) -> list[str]:
    with ResultsStore(tmp_path / "results.sqlite") as store:
        return [r.status for r in store.jobs()]


def test_json_to_a_full_device_is_one_line_and_the_check_is_recorded(job, tmp_path):
    """`--json /dev/full`, through a link in the test's folder: as root the device node could
    otherwise be replaced by a file were the write ever renamed over it again."""
    assert Path("/dev/full").is_char_device()
    (tmp_path / "full.json").symlink_to("/dev/full")
    target = "/dev/full" if os.geteuid() != 0 else "full.json"
    run = run_pathcheck([job.name, "--json", target], cwd=tmp_path)
    _one_line(run, rf"pathcheck: {re.escape(target)}: cannot write results JSON: No space left "
                   r"on device")
    assert Path("/dev/full").is_char_device()
    assert _recorded(tmp_path) == ["ok"]
    assert not [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_gcode_into_a_folder_that_cannot_exist_fails_before_the_check(job, tmp_path):
    (tmp_path / "afile").write_text("")
    run = run_pathcheck([job.name, "-o", "afile/x.nc"], cwd=tmp_path)
    _one_line(run, r"pathcheck: afile/x\.nc: cannot write G-code: /.*/afile is a file, "
                   r"expected a folder")
    assert _recorded(tmp_path) == []  # refused before the check: nothing was checked


def _file_size_limit(size: int):
    def limit() -> None:  # a full disk for this process: writes past `size` bytes fail
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
    return limit


def test_json_on_a_full_disk_leaves_nothing_partial(job, tmp_path):
    run = run_pathcheck([job.name, "--json", "out.json", "--no-store"], cwd=tmp_path,
                        preexec=_file_size_limit(20_000))
    _one_line(run, r"pathcheck: out\.json: cannot write results JSON: File too large")
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(("out", ".out"))]


def _store_with(tmp_path: Path, jobs: int) -> Path:
    path = tmp_path / "results.sqlite"
    with ResultsStore(path) as store:
        for k in range(jobs):
            store.record_job(synthetic_document(k, n=5, four_axis=False, path=f"j{k}.apt"),
                             elapsed_s=1.0)
    return path


def test_a_store_on_a_full_disk_is_one_note_and_the_batch_goes_on(tmp_path):
    store = _store_with(tmp_path, 1)
    folder = tmp_path / "night"
    folder.mkdir()
    for k in range(3):
        (folder / f"job{k}.apt").write_text(f"{k} 60\n")  # 3,600 points: ~100 KB to record
    full = 40_000  # the store opens (its 32 KB shared-memory file fits), no record fits
    assert max(p.stat().st_size for p in tmp_path.glob("results.sqlite*")) < full
    run = run_pathcheck(["batch", str(folder), "--workers", "1", "--job-function",
                         "tests.synthetic_results:synthetic_job"], cwd=tmp_path,
                        preexec=_file_size_limit(full))
    assert run.code == 1, run.why()  # the jobs' own results: findings
    assert "Traceback" not in run.stderr and "cannot rollback" not in run.stderr, run.why()
    assert "3 jobs: 0 clean, 3 with findings, 0 failed" in run.stdout, run.why()
    assert "(3 could not be recorded)" in run.stdout, run.why()
    said = " ".join(run.stderr.split())  # the progress console wraps its lines
    assert said.count("not recorded") == said.count("store error while recording a job") == 3
    with ResultsStore(store) as s:
        assert len(s.jobs()) == 1


def kill_on_seed_2(apt_path: str):
    """A batch job function whose worker is killed (SIGKILL, as the OOM killer does) on the
    job with seed 2."""
    from tests.synthetic_results import synthetic_job

    if Path(apt_path).read_text().split()[0] == "2":
        os.kill(os.getpid(), signal.SIGKILL)
    return synthetic_job(apt_path)


def test_batch_with_a_killed_worker_fails_that_job_alone(tmp_path):
    folder = tmp_path / "night"
    folder.mkdir()
    for k in range(5):
        (folder / f"job{k}.apt").write_text(f"{k} 10\n")
    run = run_pathcheck(["batch", str(folder), "--workers", "2", "--job-function",
                         "tests.test_hostile_programs:kill_on_seed_2"], cwd=tmp_path)
    assert run.code == 1 and "Traceback" not in run.stderr, run.why()
    assert "5 jobs: 0 clean, 4 with findings, 1 failed" in run.stdout, run.why()
    with ResultsStore(tmp_path / "results.sqlite") as store:
        rows = {Path(r.job_path).name: r for r in store.jobs()}
    assert {n: r.status for n, r in rows.items()} == {
        "job0.apt": "findings", "job1.apt": "findings", "job2.apt": "failed",
        "job3.apt": "findings", "job4.apt": "findings"}
    assert "died twice" in rows["job2.apt"].error


def test_report_skips_and_counts_a_row_it_cannot_read(tmp_path):
    store = _store_with(tmp_path, 3)
    with sqlite3.connect(store) as con:
        con.execute("UPDATE jobs SET arrays = ? WHERE id = 2", (b"\x78\x9cnot zlib",))
    run = run_pathcheck(["report", "--out", "r.html"], cwd=tmp_path)
    assert run.code == 0 and "Traceback" not in run.stderr, run.why()
    assert "2 jobs" in run.stdout and "1 unreadable row skipped" in run.stdout, run.why()
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["skipped_unreadable"] == 1 and [j["id"] for j in doc["jobs"]] == [1, 3]


def test_store_prune_keeps_the_newest_per_job(tmp_path):
    path = tmp_path / "results.sqlite"
    with ResultsStore(path) as store:
        for k in range(6):
            store.record_job(synthetic_document(k, n=3, four_axis=False, path=f"j{k % 2}.apt"),
                             elapsed_s=1.0, recorded_at=1e9 + k * 86400)
    run = run_pathcheck(["store", "prune", "--keep", "2"], cwd=tmp_path)
    assert run.code == 0 and "deleted 2 jobs" in run.stdout, run.why()
    with ResultsStore(path) as store:
        assert sorted(r.recorded_at for r in store.jobs()) == [1e9 + k * 86400 for k in (2, 3,
                                                                                          4, 5)]
    run = run_pathcheck(["store", "prune"], cwd=tmp_path)
    _one_line(run, r"pathcheck: store prune: expected --keep-days N or --keep N \(or both\)")


# ---------------------------------------------------------------- a bug is not bad input
def _boom(*_args, **_kwargs):
    return 1 / 0


def test_an_internal_error_exits_3_with_its_traceback_logged(job, tmp_path, monkeypatch, capsys):
    import checker.apt.toolpath_info

    monkeypatch.setenv("PATHCHECK_LOG_DIR", str(tmp_path / "logs"))
    monkeypatch.setattr(checker.apt.toolpath_info, "describe_toolpath", _boom)
    with pytest.raises(SystemExit) as ended:
        main(["info", str(job)])
    assert ended.value.code == EXIT_INTERNAL == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert err.startswith("pathcheck: internal error (a bug in pathcheck, please report it "
                          "with the log): ZeroDivisionError: division by zero; the traceback "
                          "is in ")
    (log,) = (tmp_path / "logs").iterdir()
    assert str(log) in err
    text = log.read_text()
    assert "Traceback" in text and "_boom" in text and f"pathcheck info {job}" in text


def test_out_of_memory_is_one_line_and_exit_2(job, monkeypatch, capsys):
    import checker.apt.toolpath_info

    def _huge(*_args, **_kwargs):
        raise MemoryError("Unable to allocate 28.4 PiB for an array")

    monkeypatch.setattr(checker.apt.toolpath_info, "describe_toolpath", _huge)
    with pytest.raises(SystemExit) as ended:
        main(["info", str(job)])
    assert ended.value.code == EXIT_INPUT
    assert capsys.readouterr().err.strip() == (
        "pathcheck: out of memory: Unable to allocate 28.4 PiB for an array; expected input "
        "this machine can hold")


def test_a_check_on_a_full_disk_is_one_note_not_a_failure(tmp_path):
    """`pathcheck JOB` records its check through `record`: on a full disk (SQLITE_FULL or an
    I/O error at commit, after which SQLite has already rolled back) one line, no traceback."""
    _store_with(tmp_path, 1)
    script = ("import resource, sys\n"
              "from checker.commands.check import record\n"
              "from tests.synthetic_results import synthetic_document\n"
              "doc = synthetic_document(1, n=60, four_axis=False, path='a.apt')\n"
              "resource.setrlimit(resource.RLIMIT_FSIZE, (40_000, 40_000))\n"
              "record(doc)\n")
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120,
                          env=dict(os.environ, PATHCHECK_STORE=str(tmp_path / "results.sqlite"),
                                   PYTHONPATH=str(REPO)))
    assert proc.returncode == 0, proc.stderr
    assert re.fullmatch(r"pathcheck: note: not recorded in the results store: .*results\.sqlite:"
                        r" store error while recording a job: [^\n]*", proc.stderr.strip()), \
        proc.stderr
    with ResultsStore(tmp_path / "results.sqlite") as store:
        assert len(store.jobs()) == 1


def test_a_circle_axis_too_short_to_give_a_direction_is_one_line(tmp_path):
    """Found by the fuzzer: a CIRCLE axis 1e-320 long gave numpy warnings before the error."""
    (tmp_path / "c.apt").write_text("CUTTER/6\nGOTO/1,0,0\nCIRCLE/0,0,0,1e-320,0,0\nGOTO/1,0,0\n")
    _one_line(run_pathcheck(["info", "c.apt"], cwd=tmp_path),
              r"pathcheck: c\.apt:3: CIRCLE/: expected a circle axis i,j,k of unit length, "
              r"found 9\.99989e-321,0,0")
