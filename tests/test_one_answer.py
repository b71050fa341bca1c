"""One answer everywhere: for a job whose written program has findings, the exit code, the text
summary, the results JSON, the store, the nightly report and the service reply all say
'findings' (and for a clean job all say 'ok'), because all of them read the document's own
status, decided by `checker.verdict` from the program that is written."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from checker.config import default_config
from checker.postproc.header import read_verdict
from checker.service.ops import WorkerState
from checker.service.part_cache import PartCache
from checker.service.recorder import NullRecorder
from checker.service.worker import handle
from checker.store import ResultsStore

SMALL_D12 = "samples/compressor/compressor_small_d12.apt"


def _clean_job(tmp_path):
    """A ball D6 riding on a flat floor: every pose touches, nothing penetrates."""
    (tmp_path / "floor.json").write_text(json.dumps({
        "shape": {"type": "surface", "count": 1, "data": [{
            "type": "spline", "rational": False, "dimension": 3, "degree_u": 1, "degree_v": 1,
            "knotvector_u": [0, 0, 1, 1], "knotvector_v": [0, 0, 1, 1], "size_u": 2,
            "size_v": 2, "control_points": {"points": [[-20, -20, 0], [-20, 20, 0],
                                                       [20, -20, 0], [20, 20, 0]]}}]}}))
    (tmp_path / "floor.apt").write_text(
        "PARTNO/FLOOR\nUNITS/MM\nCUTTER/6,3\nLOADTL/1\nRAPID\nGOTO/-10,0,20\nFEDRAT/500,MMPM\n"
        "GOTO/-10,0,0\nGOTO/10,0,0\nRAPID\nGOTO/10,0,20\nFINI\n")
    return tmp_path / "floor.apt"


def _run(repo, tmp_path, job, store, *args: str):
    env = dict(os.environ, PATHCHECK_STORE=str(store))
    run = subprocess.run(
        [sys.executable, "-m", "checker.cli", str(job), "-o", str(tmp_path / "job.nc"), "--json",
         str(tmp_path / "job.json"), *args], capture_output=True, text=True, cwd=repo, env=env,
        timeout=600)
    report = subprocess.run([sys.executable, "-m", "checker.cli", "report", "--out",
                             str(tmp_path / "report.html")], capture_output=True, text=True,
                            cwd=repo, env=env, timeout=600)
    assert report.returncode == 0, report.stderr
    return run, json.loads((tmp_path / "job.json").read_text())


def _service_status(job, part=None) -> str:
    state = WorkerState(config=default_config(), cache=PartCache(1 << 28))
    request = {"op": "check", "apt_path": str(job)}
    if part is not None:
        request["part"] = {"path": str(part)}
    reply, _ = handle(json.dumps(request).encode(), state, NullRecorder())
    return reply["results"]["summary"]["status"]


def test_findings_are_findings_everywhere(repo, tmp_path):
    store = tmp_path / "results.sqlite"
    run, doc = _run(repo, tmp_path, repo / SMALL_D12, store, "--on-findings", "comment")
    assert run.returncode == 1, run.stderr
    assert "FINDINGS:" in run.stdout
    assert doc["summary"]["status"] == "findings"
    # the written program is the re-oriented one; the summary gives the B of each finding
    assert doc["operations"][0]["handling"] == "re-oriented"
    assert all(f["b"] is not None for f in doc["summary"]["worst"])
    gcode = (tmp_path / "job.nc").read_text()
    assert "PATHCHECK GOUGE" in gcode or "PATHCHECK INTERFERENCE" in gcode
    assert read_verdict(gcode) == "FINDINGS"  # the program's own header says so too
    with ResultsStore(store) as s:
        (row,) = s.jobs()
    assert row.status == "findings"
    report = json.loads((tmp_path / "report.json").read_text())
    assert [j["status"] for j in report["jobs"]] == ["findings"]
    assert _service_status(repo / SMALL_D12) == "findings"


def test_clean_is_clean_everywhere(repo, tmp_path):
    store = tmp_path / "results.sqlite"
    job = _clean_job(tmp_path)
    run, doc = _run(repo, tmp_path, job, store)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "clean:" in run.stdout and doc["summary"]["status"] == "ok"
    assert "PATHCHECK" not in (tmp_path / "job.nc").read_text().replace("(PATHCHECK", "")
    assert read_verdict((tmp_path / "job.nc").read_text()) == "CLEAN"
    with ResultsStore(store) as s:
        (row,) = s.jobs()
    assert row.status == "ok"
    report = json.loads((tmp_path / "report.json").read_text())
    assert [j["status"] for j in report["jobs"]] == ["ok"]
    assert _service_status(job) == "ok"
