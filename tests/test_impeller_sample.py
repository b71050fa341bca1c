"""The 5-axis sample (samples/impeller): what the script builds, the findings at the CAM's
orientations (the hub normal: the tool's body meets the blade that leans over the passage on the
row beside it, and nowhere else), the program posted for the 5-axis machine and read back
(tips and axes within 1e-4 mm / rad), the same findings when the posted program is checked, and
the NX multi-axis jobs of mech491 posted and read back on a table-table and a head-table
machine."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from checker import verdict as vd
from checker.apt import read_cl
from checker.check import check_job, check_toolpath
from checker.check.options import CheckOptions
from checker.check.posting import post_unchecked
from checker.postproc.machine import load_machine
from checker.postproc.reader import read_gcode
from checker.postproc.replay import part_motions, toolpath_of

_SCRIPT = Path(__file__).resolve().parents[1] / "samples" / "make_samples.py"
_spec = importlib.util.spec_from_file_location("make_samples", _SCRIPT)
make_samples = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_samples)
ROUND_TRIP = 1e-4  # mm and rad


@pytest.fixture(scope="module")
def sample(repo):
    return repo / "samples" / "impeller"


@pytest.fixture(scope="module")
def checked(sample, tmp_path_factory):
    """The sample checked and posted (--on-findings stop)."""
    out = tmp_path_factory.mktemp("impeller") / "passage.nc"
    doc = check_job(sample / "passage.apt", options=CheckOptions(output=out, on_findings="stop"))
    return doc, out


def test_committed_files_are_what_the_script_builds(sample, tmp_path):
    make_samples.build_impeller(tmp_path)
    for name in ("passage.json", "passage.apt", "cc.csv"):
        a, b = (sample / name).read_text(), (tmp_path / name).read_text()
        assert a.splitlines()[0] == b.splitlines()[0]
        na = np.array([float(x) for x in a.replace(",", " ").replace("/", " ").split()
                       if x.lstrip("-").replace(".", "", 1).isdigit()])
        nb = np.array([float(x) for x in b.replace(",", " ").replace("/", " ").split()
                       if x.lstrip("-").replace(".", "", 1).isdigit()])
        assert na.shape == nb.shape and np.abs(na - nb).max() <= 1e-4 + 1e-9, name


def test_the_part_is_the_passage(sample):
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate

    part = load_part(sample / "passage.json")
    names = [s.name for s in part.surfaces]
    assert names == ["hub", "blade0_pressure", "blade0_suction", "blade1_pressure",
                     "blade1_suction"]
    hub = part.surfaces[0]
    assert hub.rational
    u, v = np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 1, 9))
    ev = evaluate(hub, u.ravel(), v.ravel())
    # a surface of revolution about Z: the meridian at every angle is the profile's
    s = np.linspace(0, 1, 9)
    rz, n = make_samples._meridian(np.repeat(s, 9).reshape(9, 9).T.ravel())
    r = np.hypot(ev.points[:, 0], ev.points[:, 1])
    np.testing.assert_allclose(np.c_[r, ev.points[:, 2]], rz, atol=1e-9)
    radial = np.c_[ev.points[:, :2] / r[:, None], np.zeros(81)]
    np.testing.assert_allclose(ev.normals, radial * n[:, :1] + [0, 0, 1] * n[:, 1:], atol=1e-9)


def _rows(apt: Path) -> np.ndarray:
    """Per CL line the row of the zig-zag it belongs to (-1 before the first)."""
    lines = apt.read_text().splitlines()
    starts = [i + 1 for i, t in enumerate(lines) if t == "RAPID"][0::2]
    return np.searchsorted(starts, np.arange(len(lines) + 2), side="right") - 1


def test_findings_at_the_cam_orientations_are_the_body_on_the_leaning_blade(checked, sample):
    doc, _ = checked
    assert [o.axis_class for o in doc.operations] == ["multi-axis"]
    assert doc.summary.status == "findings"
    row = _rows(sample / "passage.apt")
    cl = [p for p in doc.points if p.kind == "cl"]
    bad = [p for p in cl if p.verdict in vd.FINDINGS]
    assert {int(row[p.line]) for p in bad} == {0}  # the row beside blade 0 only
    assert all(p.piece == "body" and p.verdict == "interference" for p in bad)
    assert {p.surface for p in bad} == {2}  # blade0_suction
    cutting = [p for p in cl if not p.rapid and row[p.line] >= 1]
    assert cutting and not any(p.verdict in vd.FINDINGS for p in cutting)
    assert sum(p.verdict in vd.FINDINGS for p in cl) < 0.3 * len(cl)


def _cl_poses(apt: Path):
    m = read_cl(apt, require_cutter=False).motion_arrays()
    return m.tip, m.axis / np.linalg.norm(m.axis, axis=1, keepdims=True)


def _round_trip(apt: Path, program: Path, mach) -> tuple[float, float]:
    """Largest tip (mm) and axis (rad) error between the CL poses and the program's block
    ends read back through the machine's kinematics."""
    tip, axis = _cl_poses(apt)
    moves = read_gcode(program, mach.dialect, units=mach.units)
    pm = part_motions(moves, mach)
    ok = pm.known & pm.end
    d, i = cKDTree(pm.tip[ok]).query(tip)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", pm.axis[ok][i], axis), -1.0, 1.0))
    return float(d.max()), float(ang.max())


def test_the_posted_sample_reads_back_as_its_cl_poses(checked, sample):
    doc, program = checked
    text = program.read_text()
    assert "M428" in text and " A" in text and " C" in text  # TCP, both rotary words
    assert text.count("M1\n") >= 20  # a stop before each flagged move
    mach = load_machine(make_samples.IMP_MACHINE)
    tip_err, axis_err = _round_trip(sample / "passage.apt", program, mach)
    assert tip_err <= ROUND_TRIP and axis_err <= ROUND_TRIP


def test_checking_the_posted_program_gives_the_same_findings(checked, sample):
    doc, program = checked
    mach = load_machine(make_samples.IMP_MACHINE)
    moves = read_gcode(program, mach.dialect, units=mach.units)
    motions = part_motions(moves, mach)
    cutter = read_cl(sample / "passage.apt").operations[0].cutter
    tp = toolpath_of(motions, path=program, units="mm", cutter=cutter)
    again = check_toolpath(tp, sample / "passage.json", CheckOptions(cutter=cutter, machine=mach))
    # the program's poses at the CL poses: the same verdicts
    tip, _ = _cl_poses(sample / "passage.apt")
    cl = [p for p in doc.points if p.kind == "cl"]
    gc = [p for p in again.points if p.kind == "cl"]
    gtips = np.array([p.tip for p in gc])
    d, i = cKDTree(gtips).query(np.array([p.tip for p in cl]))
    assert d.max() <= ROUND_TRIP
    mine = np.array([p.verdict in vd.FINDINGS for p in cl])
    theirs = np.array([gc[k].verdict in vd.FINDINGS for k in i])
    np.testing.assert_array_equal(mine, theirs)
    # the program's other poses (approach, steps of its turning blocks) add no new place:
    # each finding there lies within a few mm of a finding of the CL check (poses or moves)
    where = np.array([p.tip for p in doc.points if p.verdict in vd.FINDINGS])
    extra = np.array([p.tip for p in again.points if p.verdict in vd.FINDINGS])
    assert cKDTree(where).query(extra)[0].max() < 5.0
    assert len(tip) == len(cl)


MECH491 = ["APT_Variable_Axis.txt", "APT_Project2.txt"]


def _fine(name: str):
    """A shipped machine with finer program increments (1e-6 in / 1e-5 mm / 1e-6 deg): the
    round trip then measures the kinematics, not the control's rounding."""
    mach = load_machine(name)
    fmt = mach.format.model_copy(update={"linear_increment": 1e-5, "inch_increment": 1e-6,
                                         "rotary_increment": 1e-6})
    return mach.model_copy(update={"format": fmt})


@pytest.mark.parametrize("machine", ["fanuc-trunnion-ac", "heidenhain-head-table-bc"])
@pytest.mark.parametrize("job", MECH491)
def test_mech491_multi_axis_jobs_post_and_read_back(realdata, tmp_path, job, machine):
    apt = realdata / "mech491-nx-clsf" / job
    mach = _fine(machine)
    out = post_unchecked(apt, tmp_path / "x.nc", machine=mach)
    tip_err, axis_err = _round_trip(apt, out, mach)
    assert tip_err <= ROUND_TRIP and axis_err <= ROUND_TRIP


@pytest.mark.parametrize("machine", ["linuxcnc-xyzac-trt", "fanuc-trunnion-ac"])
def test_the_flank_sample_posts_and_reads_back(repo, tmp_path, machine):
    """The 5-axis flank pass (samples/flank/hypar.apt: the axis turns along the rulings) posted
    for a 5-axis machine reads back as its CL poses."""
    apt = repo / "samples" / "flank" / "hypar.apt"
    mach = _fine(machine)
    out = post_unchecked(apt, tmp_path / "hypar.nc", machine=mach)
    tip_err, axis_err = _round_trip(apt, out, mach)
    assert tip_err <= ROUND_TRIP and axis_err <= ROUND_TRIP
