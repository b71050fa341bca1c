"""`pathcheck check-gcode` checks an existing program like the CL job it was posted from."""

from __future__ import annotations

import pytest

from checker.cli import main
from checker.job import check_job


def _exit_code(args) -> int:
    with pytest.raises(SystemExit) as ex:
        main(args)
    return ex.value.code


@pytest.mark.parametrize("machine", ["fanuc-hmc", "linuxcnc-hmc"])
def test_posted_program_checks_like_its_cl_job(repo, tmp_path, machine):
    job = repo / "samples/mould/mould.apt"
    program = tmp_path / f"mould-{machine}.nc"
    doc = check_job(job, output=program, machine=machine)
    assert program.is_file()
    out = tmp_path / "gcode.json"
    part = str(repo / "samples/mould/mould.json")
    args = ["check-gcode", str(program), "--machine", machine, "--part", part,
            "--cutter", "CUTTER/10,5", "--json", str(out), "--no-store"]
    assert _exit_code(args) == 0
    from checker.results import ResultsDocument

    again = ResultsDocument.model_validate_json(out.read_text())
    assert again.job.dialect == "gcode"
    assert again.summary.cc_points == doc.summary.cc_points
    assert again.summary.counts.ok == again.summary.points
    assert again.summary.largest_safe_cutter == pytest.approx(doc.summary.largest_safe_cutter,
                                                              abs=1e-3)
    # a ball larger than the bowl's smallest concave radius gouges it
    big = args.copy()
    big[big.index("CUTTER/10,5")] = "CUTTER/40,20"
    assert _exit_code(big) == 1
