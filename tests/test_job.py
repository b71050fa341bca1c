"""`check_job` and `pathcheck JOB.apt` on real files: a ball end-mill running along a floor
towards a wall (known answer: the allowable radius is the distance to the wall, the real
cutter penetrates by x + r - X beyond it), and the bundled mould sample."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from wall_jobs import X_WALL, wall_pass, write_wall_part

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.results import ResultsDocument

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wall_job(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("walljob")
    write_wall_part(d / "wall.json")
    lines = ["PARTNO/WALL", "UNITS/MM", *wall_pass("CUTTER/10,5", 1, 0.0, 5.0), "FINI"]
    (d / "wall.apt").write_text("\n".join(lines) + "\n")
    return d / "wall.apt"


def test_check_job_wall(wall_job):
    """The CL poses along the floor: the allowable radius is the distance to the wall, and once
    the ball reaches the wall the real cutter penetrates by x + r - X; the rapid retract beside
    the wall is a crash."""
    doc = check_job(wall_job)
    ResultsDocument.model_validate_json(doc.model_dump_json())
    pts = [p for p in doc.points if p.kind == "cl" and not p.rapid]
    x = np.array([p.tip[0] for p in pts])
    verdict = np.array([p.verdict for p in pts])
    clear = x <= X_WALL - 5 - 0.5
    assert np.isin(verdict[clear], ["ok", "within_tolerance"]).all()
    allow = np.array([p.allowable for p in pts])[clear]
    assert np.allclose(allow, X_WALL - x[clear], atol=1e-4)      # r* = distance to the wall
    far = x >= X_WALL - 5 + 0.5
    assert np.isin(verdict[far], ["gouge", "interference"]).all()
    depth = np.array([p.depth for p in pts])
    assert np.allclose(depth[far], x[far] + 5 - X_WALL, atol=1e-3)  # penetration into the wall
    rapid = [p for p in doc.points if p.rapid and p.kind == "cl"]
    assert rapid[-1].verdict == "crash" and rapid[-1].depth == pytest.approx(2.0, abs=1e-3)
    assert doc.summary.worst[0].depth == pytest.approx(2.0, abs=1e-3)
    assert doc.summary.status == "findings"


def test_cli_exit_codes_and_json(wall_job, tmp_path):
    """`pathcheck JOB.apt` as a real process: exit 1 with findings, JSON written; exit 2 and one
    line naming the file for a missing part."""
    out = tmp_path / "r.json"
    run = subprocess.run([sys.executable, "-m", "checker.cli", str(wall_job), "--json", str(out)],
                         capture_output=True, text=True, cwd=REPO)
    assert run.returncode == 1, run.stderr
    assert "worst findings" in run.stdout and "largest safe" in run.stdout
    doc = json.loads(out.read_text())
    s = doc["summary"]
    assert s["status"] == "findings"
    assert sum(s["counts"].values()) == s["cl_points"] + s["move_points"]
    bad = subprocess.run([sys.executable, "-m", "checker.cli", str(wall_job), "--part",
                          str(tmp_path / "missing.json")], capture_output=True, text=True, cwd=REPO)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert "missing.json" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1


def test_mould_sample_clean_and_larger_cutter_flagged():
    apt = REPO / "samples" / "mould" / "mould.apt"
    doc = check_job(apt)
    assert doc.summary.status == "ok"  # the CAM path with D10 ball is clean, along its moves too
    c = doc.summary.counts
    assert c.ok + c.within_tolerance == doc.summary.cl_points + doc.summary.move_points
    assert doc.summary.largest_safe_cutter > 5.0
    big = check_job(apt, options=CheckOptions(
        cutter=f"CUTTER/{2 * doc.summary.largest_safe_cutter + 2:.3f},"
               f"{doc.summary.largest_safe_cutter + 1:.3f}"))
    assert big.summary.counts.gouge + big.summary.counts.interference > 0
