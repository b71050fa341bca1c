"""The command contract for CAM posts (docs/cam-command.md), run as a post runs it: the
example of the document executed as it is, `pathcheck check JOB --json -` in a separate
process, stdout parsed as one JSON document and validated against the published results
schema, the exit code against `summary.status`; bad input leaves stdout empty."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest

from checker.resources import resource

REPO = Path(__file__).resolve().parents[1]
SMALL = REPO / "samples" / "compressor" / "compressor_small"
PATHCHECK = (sys.executable, "-m", "checker.cli")


def _example() -> dict:
    """The Python example of docs/cam-command.md, executed: its namespace."""
    text = (REPO / "docs" / "cam-command.md").read_text()
    (code,) = re.findall(r"```python\n(.*?)```", text, re.S)
    namespace: dict = {}
    exec(compile(code, "docs/cam-command.md", "exec"), namespace)  # noqa: S102
    return namespace


@pytest.fixture(autouse=True)
def _this_tree(monkeypatch, tmp_path):
    monkeypatch.setenv("PYTHONPATH", str(REPO))  # the child runs this worktree's code
    monkeypatch.setenv("PATHCHECK_LOG_DIR", str(tmp_path / "log"))


def _job(folder: Path, name: str, cutter: str = "CUTTER/6,3", broken: bool = False) -> Path:
    """The approach and first 5 feed moves of the small compressor job, its part beside it."""
    lines = SMALL.with_suffix(".apt").read_text().splitlines()[:16]
    assert lines[4] == "CUTTER/6,3" and lines[10].startswith("GOTO/")
    lines[4] = cutter
    if broken:
        lines[10] = "GOTO/12.1058,ABC,86.0163"
    job = folder / f"{name}.apt"
    job.write_text("\n".join([*lines, "END", "FINI", ""]))
    (folder / f"{name}.json").write_bytes(SMALL.with_suffix(".json").read_bytes())
    return job


def _schema() -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(
        json.loads(resource("schemas", "results.schema.json").read_text()))


def test_stdout_is_the_results_document_alone_and_the_exit_code_its_status(tmp_path):
    for name, cutter, code, status in (("clean", "CUTTER/6,3", 0, "ok"),
                                       ("big", "CUTTER/12,6", 1, "findings")):
        job = _job(tmp_path, name, cutter)
        run = subprocess.run([*PATHCHECK, "check", str(job), "--json", "-", "--no-store"],
                             capture_output=True, text=True, timeout=600)
        doc = json.loads(run.stdout)  # the whole of stdout is one JSON document
        _schema().validate(doc)
        assert (run.returncode, doc["summary"]["status"]) == (code, status), run.stderr
        assert doc["job"]["path"] == str(job)
        assert doc["job"]["cutter_size"] == float(cutter.split(",")[1])  # ball: r = D/2
        assert "poses" in run.stderr  # the summary for a person went to stderr
    assert doc["summary"]["counts"]["gouge"] > 0 and doc["summary"]["worst"]


def test_the_documented_example_as_a_post_runs_it(tmp_path, capsys):
    check = _example()["check"]
    job = _job(tmp_path, "blade")
    code, doc = check(job, tmp_path / "blade.nc", pathcheck=PATHCHECK)
    assert code == 0 and doc["summary"]["status"] == "ok"
    assert doc["gcode"] == str(tmp_path / "blade.nc")
    assert (tmp_path / "blade.nc").read_text().startswith("%")

    code, doc = check(_job(tmp_path, "big", "CUTTER/12,6"), tmp_path / "big.nc",
                      pathcheck=PATHCHECK)
    shown = capsys.readouterr().err.splitlines()
    assert code == 1 and doc["summary"]["status"] == "findings"
    assert len(shown) == len(doc["summary"]["worst"]) > 0
    assert shown[0].startswith(f"line {doc['summary']['worst'][0]['line']}: gouge ")


def test_bad_input_is_exit_2_one_line_on_stderr_and_nothing_on_stdout(tmp_path):
    job = _job(tmp_path, "broken", broken=True)
    run = subprocess.run([*PATHCHECK, "check", str(job), "--json", "-", "--no-store"],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 2 and run.stdout == ""
    (line,) = run.stderr.splitlines()
    assert line.startswith(f"pathcheck: {job}:11: ") and "ABC" in line
