"""The machine check on every way in, on the descent job of tests/collide_machines.py (the
spindle nose of the head-head machine coming down onto a block, the contact's Z in closed form):
the main command `pathcheck JOB.apt` with and without a part, the posted program (`-o`) under
`--on-findings comment|stop|refuse` read back, and a machine check the machine cannot make
refused before the run. The service and the batch folder: tests/test_collide_service.py,
tests/test_collide_batch.py."""

from __future__ import annotations

import json
import re

import pytest
from collide_machines import DESCENT_LEAST, descent_job, machine_file, the_descent_finding
from requires import require_extra

from checker.cli import main

require_extra("coal", "machine")


def _run(args: list[str]) -> int:
    with pytest.raises(SystemExit) as ex:
        main(args)
    return int(ex.value.code)


@pytest.mark.parametrize("part", [True, False], ids=["with-part", "no-part"])
def test_the_main_command_finds_the_nose_on_the_block(tmp_path, part):
    job, machine = descent_job(tmp_path, part=part)
    out = tmp_path / "out.json"
    code = _run([str(job), "--machine", str(machine), "--machine-clearance", "0.5", "--json",
                 str(out), "--no-store"])
    doc = json.loads(out.read_text())
    assert code == 1 and doc["summary"]["status"] == "findings"
    assert doc["summary"]["counts"]["machine"] == 1
    assert doc["machine"]["clearance"] == 0.5
    the_descent_finding(doc["machine"])
    assert (doc["job"]["part"] is None) != part


def test_the_main_command_is_clean_with_a_smaller_clearance_short_of_the_block(tmp_path):
    """The descent stops 11.15 mm into the block: with the job raised by 12 mm (lines 7, 8 at
    Z -8) the nose stays 0.85 mm above it, clear of a 0.5 mm clearance; the near-miss listing
    gives 0.85."""
    job, machine = descent_job(tmp_path)
    job.write_text(job.read_text().replace(",-20", ",-8"))
    out = tmp_path / "out.json"
    code = _run([str(job), "--machine", str(machine), "--machine-clearance", "0.5", "--json",
                 str(out), "--no-store"])
    m = json.loads(out.read_text())["machine"]
    assert code == 0 and m["findings"] == []
    near = {(p["a"], p["b"]): p["least"] for p in m["near_misses"]}
    assert abs(near[("block", "nose")] - 0.85) < 0.005, near


@pytest.mark.parametrize("policy", ["comment", "stop"])
def test_the_posted_program_names_the_collision_before_its_move(tmp_path, policy):
    job, machine = descent_job(tmp_path)
    nc = tmp_path / "descent.nc"
    code = _run([str(job), "--machine", str(machine), "--machine-clearance", "0.5", "-o",
                 str(nc), "--on-findings", policy, "--no-store"])
    assert code == 1
    lines = nc.read_text().splitlines()
    said = [i for i, t in enumerate(lines) if "MACHINE BLOCK / NOSE" in t]
    assert len(said) == 1, lines
    text = lines[said[0]]
    least = float(re.search(r"LEAST (-?\d+\.\d+)", text).group(1))
    assert abs(least - DESCENT_LEAST) < 1e-3, text
    after = lines[said[0] + 1:]
    if policy == "stop":
        assert after[0] in ("M1", "M01"), after[:2]  # the optional stop
        after = after[1:]
    assert re.match(r"G1 .*Z-20\.0", after[0]), after[0]  # the move of line 7
    assert any("PATHCHECK VERDICT FINDINGS: machine 1" in t for t in lines)


def test_refuse_writes_nothing_for_a_machine_collision(tmp_path, capsys):
    job, machine = descent_job(tmp_path)
    nc = tmp_path / "descent.nc"
    code = _run([str(job), "--machine", str(machine), "--machine-clearance", "0.5", "-o",
                 str(nc), "--no-store"])
    assert code == 1 and not nc.exists()
    err = capsys.readouterr().err
    assert "not written: the program has machine 1" in err, err


def test_a_machine_without_components_is_refused_before_the_run(tmp_path, capsys):
    job, _ = descent_job(tmp_path)
    bare = machine_file(tmp_path, "linuxcnc-head-head-ac", "")
    code = _run([str(job), "--machine", str(bare), "--machine-check", "--no-store"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err, err
    assert "--machine-check: machine 'linuxcnc-head-head-ac' has no components" in err


@pytest.mark.parametrize("args, said", [
    (["--machine-clearance", "-1"], "--machine-clearance -1: expected a distance from 0 to 10000"),
    (["--machine-check", "--no-check", "-o", "x.nc"], "--no-check posts without checking: "
                                                       "remove --machine-check"),
])
def test_a_machine_check_that_cannot_run_is_a_usage_error(tmp_path, capsys, args, said):
    job, machine = descent_job(tmp_path)
    code = _run([str(job), "--machine", str(machine), "--no-store", *args])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and said in err, err
