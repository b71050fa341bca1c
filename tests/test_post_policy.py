"""Posting policy on real files: a ball end-mill running along a floor into a wall (gouge,
interference and a crash at known lines, as in test_job.py) and a clean two-tool job on the
same part. `--on-findings refuse` (the default) writes nothing and exits 1 with one line (a
real CLI process), `stop` puts an optional stop M01 before each offending move, `comment` only
the comments; the header block (source, ISO 8601 date, version, machine, every tool, the
program's own verdict) in every dialect without changing motion; `--no-check` posts without a
part; the part beside the job whatever the case of its name; the service's `on_findings`."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
from wall_jobs import wall_pass, write_wall_part

from checker import __version__
from checker.check import check_job
from checker.check.options import CheckOptions
from checker.errors import PathcheckError
from checker.geometry import find_part_beside
from checker.postproc.dialects import DIALECTS
from checker.postproc.header import read_verdict
from checker.postproc.machine import load_machine
from checker.postproc.reader import read_gcode_text
from checker.verdict import FINDINGS

REPO = Path(__file__).resolve().parents[1]
_FLAG = re.compile(r"^\(PATHCHECK ([A-Z]+) CL LINE (\d+)")


@pytest.fixture(scope="module")
def jobs(tmp_path_factory) -> Path:
    """wall.apt: a ball D10 along the floor (z = 0) into the wall at x = 8 (findings from CL
    line 35 on, the rapid out of the wall a crash); clean.apt: a ball D10 then a ball D6 (tools
    1 and 2) along the floor, clear of the wall. Each with its part beside it."""
    d = tmp_path_factory.mktemp("policy")
    write_wall_part(d / "wall.json")
    shutil.copy(d / "wall.json", d / "clean.json")
    head = ["PARTNO/POLICY", "UNITS/MM"]
    (d / "wall.apt").write_text("\n".join(
        [*head, *wall_pass("CUTTER/10,5", 1, 0.0, 5.0), "FINI"]) + "\n")
    (d / "clean.apt").write_text("\n".join(
        [*head, *wall_pass("CUTTER/10,5", 1, 0.0, 0.0), *wall_pass("CUTTER/6,3", 2, 5.0, 1.0),
         "FINI"]) + "\n")
    return d


def _cli(*args: str, cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "checker.cli", *args], capture_output=True,
                          text=True, cwd=cwd, env={**os.environ, **(env or {}),
                                                   "PYTHONPATH": str(REPO)}, timeout=600)


def _motion(text: str) -> np.ndarray:
    """X Y Z B of every motion row our Fanuc reader reads (nan: unknown)."""
    read = read_gcode_text(text, "fanuc")
    return np.c_[read.xyz, read.abc]


def _header(text: str) -> list[str]:
    """The comment lines right after the program start ('%', 'O1000 (NAME)')."""
    out = []
    for line in text.splitlines()[2:]:
        if not line.startswith("("):
            return out
        out.append(line)
    return out


def test_refuse_writes_nothing_and_exits_1(jobs, tmp_path):
    """The default policy, as a real process: exit 1, one line on stderr naming the program
    and the counts and how to override; no G-code and nothing else left behind; the results
    JSON written and the check recorded."""
    for name in ("wall.apt", "wall.json"):
        shutil.copy(jobs / name, tmp_path / name)
    store = tmp_path / "store" / "results.sqlite"
    run = _cli("wall.apt", "-o", "wall.nc", "--json", "results.json", cwd=tmp_path,
               env={"PATHCHECK_STORE": str(store)})
    assert run.returncode == 1, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    assert lines[0].startswith("pathcheck: wall.nc: not written: the program has gouge ")
    assert "--on-findings stop" in lines[0] and "comment" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "results.json", "store", "wall.apt", "wall.json"]
    doc = json.loads((tmp_path / "results.json").read_text())
    assert doc["summary"]["status"] == "findings" and doc["gcode"] is None
    said = dict(re.findall(r"(gouge|interference|holder|crash) (\d+)", lines[0]))
    assert said == {k: str(v) for k, v in doc["summary"]["counts"].items()
                    if k in FINDINGS and v}
    from checker.store import ResultsStore

    with ResultsStore(store) as recorded:
        assert len(recorded.jobs()) == 1


@pytest.fixture(scope="module")
def posted(jobs, tmp_path_factory) -> dict:
    """The wall job posted with `stop` and with `comment`: {policy: (document, text)}."""
    out = tmp_path_factory.mktemp("posted")
    got = {}
    for policy in ("stop", "comment"):
        doc = check_job(jobs / "wall.apt", options=CheckOptions(output=out / f"{policy}.nc",
                                                            on_findings=policy))
        got[policy] = doc, Path(doc.gcode).read_text()
    return got


def test_stop_puts_an_optional_stop_before_each_offending_move(posted):
    doc, text = posted["stop"]
    lines = text.splitlines()
    flags = [k for k, line in enumerate(lines) if _FLAG.match(line)]
    # the CL lines flagged are those of the document's findings at CL poses
    flagged = {int(_FLAG.match(lines[k]).group(2)) for k in flags}
    found = {p.line for p in doc.points if p.kind == "cl" and p.verdict in FINDINGS}
    assert flagged == found and len(found) >= 4
    assert min(found) == 35  # the ball (r 5) reaches the wall (x 8) past x = 3, CL line 35
    for k in flags:  # comment, M01, then the offending move
        assert re.fullmatch(r"N\d+ M01", lines[k + 1]), lines[k:k + 3]
        assert re.match(r"N\d+ (G0[01] )?[XYZB]", lines[k + 2]), lines[k:k + 3]
    assert sum(bool(re.fullmatch(r"N\d+ M01", line)) for line in lines) == len(flags)
    # the stops change no motion: the same moves as the program with comments only
    assert np.array_equal(_motion(text), _motion(posted["comment"][1]), equal_nan=True)


def test_comment_writes_the_flags_and_the_verdict_with_the_documents_counts(posted):
    doc, text = posted["comment"]
    assert "M01" not in text
    assert sum(bool(_FLAG.match(line)) for line in text.splitlines()) == len(
        {p.line for p in doc.points if p.kind == "cl" and p.verdict in FINDINGS})
    (verdict,) = [line for line in _header(text) if "VERDICT" in line]
    counts = doc.summary.counts
    want = ", ".join(f"{k} {getattr(counts, k)}" for k in FINDINGS if getattr(counts, k))
    assert verdict == f"(PATHCHECK VERDICT FINDINGS: {want})"
    assert read_verdict(text) == "FINDINGS"


def test_header_of_a_clean_two_tool_job(jobs, tmp_path):
    doc = check_job(jobs / "clean.apt", options=CheckOptions(output=tmp_path / "clean.nc"))
    assert doc.summary.status == "ok" and len(doc.operations) == 2
    text = Path(doc.gcode).read_text()
    head = _header(text)
    stamp = re.fullmatch(r"\(PATHCHECK (\S+) POSTED (\S+)\)", head[0])
    assert stamp.group(1) == __version__
    posted_at = datetime.fromisoformat(stamp.group(2))
    assert posted_at.utcoffset() is not None  # local time with its offset
    assert abs((datetime.now().astimezone() - posted_at).total_seconds()) < 3600
    assert head[1:] == [f"(SOURCE {jobs / 'clean.apt'})", "(MACHINE fanuc-hmc)",
                        "(TOOL 1 CUTTER/10.0,5.0,0.0,5.0,0.0,0.0,0.0)",
                        "(TOOL 2 CUTTER/6.0,3.0,0.0,3.0,0.0,0.0,0.0)",
                        "(PATHCHECK VERDICT CLEAN)"]
    assert re.findall(r"T(\d+) M06", text) == ["01", "02"]  # every tool the program calls
    assert read_verdict(text) == "CLEAN"


@pytest.mark.parametrize(("name", "x", "b"), [("fanuc-hmc", "X1.235", "B17.125"),
                                              ("linuxcnc-hmc", "X1.23457", "B17.12524")])
def test_words_on_the_machines_increments(name, x, b):
    """#19's `B17.12524`: Fanuc IS-B takes 0.001 mm and 0.001 deg, LinuxCNC's file 0.00001."""
    from checker.postproc.kinematics import axis_from_rotation
    from checker.postproc.post import PostMoves, post_program

    b_deg = np.array([0.0, 17.12524])
    tip = np.array([[0.0, 0.0, 50.0], [0.0, 0.0, 50.0]])
    centre = load_machine(name).kinematics.table_center
    assert centre == (0.0, 0.0, 0.0)
    # a tip whose machine X is 1.234567 at B 17.12524: on the table, turned back by B
    r = np.radians(b_deg[1])
    tip[1] = [1.234567 * np.cos(r) - 50.0 * np.sin(r), 0.0, 1.234567 * np.sin(r) + 50.0 * np.cos(r)]
    machine = load_machine(name)
    moves = PostMoves.build(tip, b_deg, rapid=[True, False], feed=300.0, tool=1)
    assert np.allclose(moves.axis, axis_from_rotation(np.radians(b_deg)))
    words = re.findall(r"(?<![A-Z(])([XB]-?\d+\.\d+)", post_program(moves, machine))
    assert x in words and b in words


@pytest.mark.parametrize("dialect", list(DIALECTS))
def test_header_in_every_dialect_changes_no_motion(jobs, dialect):
    from checker.apt import read_cl
    from checker.postproc.post import moves_from_toolpath, post_program

    machine = load_machine("fanuc-hmc").with_dialect(dialect)
    moves = moves_from_toolpath(read_cl(jobs / "clean.apt"))
    text = post_program(moves, machine, program_name="CLEAN",
                        tools=["1 CUTTER/10", "2 CUTTER/6"], verdict="CLEAN")
    mark = re.escape(DIALECTS[dialect].comment_open)
    header = [line for line in text.splitlines()
              if re.match(rf"^{mark} ?(PATHCHECK|SOURCE|MACHINE|TOOL) ", line)]
    assert len(header) == 6 and read_verdict(text) == "CLEAN"
    assert header[-1].strip("()") in ("PATHCHECK VERDICT CLEAN", "; PATHCHECK VERDICT CLEAN")
    bare = "\n".join(line for line in text.splitlines() if line not in header) + "\n"
    ours, without = read_gcode_text(text, dialect), read_gcode_text(bare, dialect)
    assert len(ours.xyz) > 20
    assert np.array_equal(np.c_[ours.xyz, ours.abc], np.c_[without.xyz, without.abc],
                          equal_nan=True)


def test_no_check_posts_without_a_part(jobs, tmp_path):
    """`pathcheck boss.apt -o boss.nc --no-check` with no CAD at hand: written, NOT CHECKED,
    the same motion as the checked program of the same job; without --no-check the missing
    part is exit 2 naming the way out."""
    shutil.copy(jobs / "clean.apt", tmp_path / "boss.apt")
    missing = _cli("boss.apt", "-o", "boss.nc", cwd=tmp_path)
    assert missing.returncode == 2 and "--no-check" in missing.stderr
    assert not (tmp_path / "boss.nc").exists()
    run = _cli("boss.apt", "-o", "boss.nc", "--no-check", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "NOT CHECKED" in run.stdout
    text = (tmp_path / "boss.nc").read_text()
    assert read_verdict(text) == "NOT CHECKED"
    assert "(TOOL 2 CUTTER/6.0,3.0,0.0,3.0,0.0,0.0,0.0)" in _header(text)
    checked = check_job(jobs / "clean.apt",
                        options=CheckOptions(output=tmp_path / "checked.nc"))
    assert np.array_equal(_motion(text), _motion(Path(checked.gcode).read_text()),
                          equal_nan=True)
    bad = _cli("boss.apt", "-o", "b2.nc", "--no-check", "--json", "r.json", cwd=tmp_path)
    assert bad.returncode == 2 and "--no-check" in bad.stderr and "Traceback" not in bad.stderr


def test_part_beside_the_job_whatever_the_case(jobs, tmp_path):
    shutil.copy(jobs / "clean.apt", tmp_path / "JOB.apt")
    shutil.copy(jobs / "clean.json", tmp_path / "Job.JSON")
    assert find_part_beside(tmp_path / "JOB.apt") == tmp_path / "Job.JSON"
    assert check_job(tmp_path / "JOB.apt").summary.status == "ok"
    (tmp_path / "job.step").write_text("")  # STEP comes first, whatever its case
    (tmp_path / "JOB.Step").write_text("")
    with pytest.raises(PathcheckError) as err:
        find_part_beside(tmp_path / "JOB.apt")
    assert "more than one part beside the job (JOB.Step, job.step)" in str(err.value)
    assert str(err.value).startswith(str(tmp_path / "JOB.apt"))


def test_service_check_refuses_or_posts_as_asked(jobs):
    from checker.config import default_config
    from checker.service.ops import WorkerState
    from checker.service.part_cache import PartCache
    from checker.service.recorder import NullRecorder
    from checker.service.worker import handle

    state = WorkerState(config=default_config(), cache=PartCache(1 << 28))
    base = {"op": "check", "apt": (jobs / "wall.apt").read_text(), "name": "wall",
            "part": {"path": str(jobs / "wall.json")}, "post": True}
    replies = {}
    for policy in (None, "stop"):
        request = base if policy is None else {**base, "on_findings": policy}
        replies[policy], _ = handle(json.dumps(request).encode(), state, NullRecorder())
    refused, stopped = replies[None], replies["stop"]
    assert refused["ok"] and "gcode" not in refused
    assert refused["refused"].startswith("G-code not written: the program has gouge ")
    assert refused["results"]["summary"]["status"] == "findings"
    assert stopped["ok"] and "refused" not in stopped
    assert read_verdict(stopped["gcode"]) == "FINDINGS" and "M01" in stopped["gcode"]
    import jsonschema  # both replies are what the published reply schema describes

    from checker.resources import resource
    schema = json.loads((resource("schemas") / "service-reply.schema.json").read_text())
    for reply in (refused, stopped):
        jsonschema.validate(json.loads(json.dumps(reply)), schema)
