"""`pathcheck check-gcode` checks an existing program like the CL job it was posted from."""

from __future__ import annotations

import pytest

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.cli import main


def _exit_code(args) -> int:
    with pytest.raises(SystemExit) as ex:
        main(args)
    return ex.value.code


@pytest.mark.parametrize("machine", ["fanuc-hmc", "linuxcnc-hmc", "siemens-trunnion-bc"])
def test_posted_program_checks_like_its_cl_job(repo, tmp_path, machine):
    job = repo / "samples/mould/mould.apt"
    program = tmp_path / f"mould-{machine}.nc"
    doc = check_job(job, options=CheckOptions(output=program, machine=machine))
    assert program.is_file()
    out = tmp_path / "gcode.json"
    part = str(repo / "samples/mould/mould.json")
    args = ["check-gcode", str(program), "--machine", machine, "--part", part,
            "--cutter", "CUTTER/10,5", "--json", str(out), "--no-store"]
    assert _exit_code(args) == 0
    from checker.results import ResultsDocument

    again = ResultsDocument.model_validate_json(out.read_text())
    assert again.job.dialect == "gcode"
    # the CL points of the job are the program's points (the summary names them cl_points, or
    # cc_points in the older results document); no findings either way
    points = [getattr(d.summary, "cl_points", None) or d.summary.cc_points for d in (again, doc)]
    assert points[0] == points[1]
    assert again.summary.counts.gouge == 0 and again.summary.counts.interference == 0
    assert again.summary.largest_safe_cutter == pytest.approx(doc.summary.largest_safe_cutter,
                                                              abs=1e-3)
    if machine != "fanuc-hmc":
        return  # the reading differs per machine; the verdict that follows does not
    # a ball larger than the bowl's smallest concave radius gouges it
    big = args.copy()
    big[big.index("CUTTER/10,5")] = "CUTTER/24,12"
    assert _exit_code(big) == 1


@pytest.mark.parametrize("machine", ["siemens-trunnion-bc", "linuxcnc-head-head-ac",
                                     "heidenhain-head-table-bc", "fanuc-vmc-a"])
def test_five_axis_machine_program_reads_back_to_the_cl_motion(repo, tmp_path, machine):
    """The mould job posted for a 5-axis (or vertical A) machine, with or without TCP: the tool
    path check-gcode hands to the checker is the CL file's, point for point."""
    import numpy as np

    from checker.apt import read_cl
    from checker.postproc.machine import load_machine
    from checker.postproc.post import post_toolpath
    from checker.postproc.reader import read_gcode
    from checker.postproc.replay import part_motions, toolpath_of

    job = read_cl(repo / "samples/mould/mould.apt")
    cl = job.motion_arrays(arc_chord_tol=0.01)
    program = post_toolpath(job, tmp_path / "mould.nc", machine=machine,
                            b_deg=np.zeros(len(cl.tip)), arc_chord_tol=0.01)
    m = load_machine(machine)
    motions = part_motions(read_gcode(program, m.dialect, units=m.units), m)
    back = toolpath_of(motions, path=program, units="mm", cutter=None).motion_arrays()
    from scipy.spatial import cKDTree

    cut = ~np.asarray(cl.rapid)
    # each CL cutting point is a program point (the program adds approach and retract points),
    # to the rounding of the X Y Z words (the axis is +Z throughout: the rotary words are exact)
    dist, _ = cKDTree(back.tip).query(cl.tip[cut])
    assert dist.max() <= np.sqrt(3) * m.format.linear_increment / 2 + 1e-9
    assert np.abs(back.axis - [0.0, 0.0, 1.0]).max() < 1e-9
