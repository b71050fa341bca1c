"""`pathcheck JOB.apt --reorient` on multi-axis jobs (`checker.five_axis.reorient`, issue #20): the
impeller sample has findings at the CAM's axes and none after re-orientation; every written
contact pose is feasible by an independent judge (GJK depths) and reachable by the machine away
from its singular direction; the results document carries each point's lead, tilt and feasible
set (bits of the operation's grid) that match the plan; the posted program reads back within
1e-4 and checks clean; the planner moves the rotary axes less than the greedy smoothing of Jun, Lee
and Cha (2002) on the same feasible sets. Closed forms for the helpers (least rotation, the
machine's reach)."""

from __future__ import annotations

import base64
import math

import numpy as np
import pytest
from mesh_gjk_oracle import gjk_pose_depths
from scipy.spatial import cKDTree

from checker.apt import read_cl
from checker.check import check_program, check_toolpath
from checker.check.options import CheckOptions
from checker.check.posting import post_checked
from checker.five_axis.lead_tilt import axes_from_angles
from checker.five_axis.poses import PoseJudge
from checker.five_axis.reorient import (
    contact_segments,
    feed_directions,
    least_rotation,
    machine_reach,
)
from checker.postproc.kinematics import Chain
from checker.postproc.machine import load_machine
from checker.postproc.reader import read_gcode
from checker.postproc.replay import part_motions, toolpath_of
from checker.results import findings_in

ROUND_TRIP = 1e-4  # mm and rad


@pytest.fixture(scope="module")
def job(repo):
    return repo / "samples" / "impeller" / "passage.apt"


@pytest.fixture(scope="module")
def reoriented(job, tmp_path_factory):
    """The sample checked with --reorient and posted (--on-findings stop)."""
    out = tmp_path_factory.mktemp("reorient") / "passage.nc"
    checked = check_program(read_cl(job), options=CheckOptions(reorient=True, output=out))
    post_checked(checked, out, "stop")
    return checked, out


def test_reorientation_removes_the_findings(reoriented):
    checked, _ = reoriented
    doc = checked.document
    assert doc.operations[0].axis_class == "multi-axis"
    assert doc.operations[0].handling == "re-oriented"
    assert findings_in(doc.summary.counts_cam) >= 20  # the body on blade 0, the retract's crash
    assert findings_in(doc.summary.counts) == 0 and doc.summary.status == "ok"
    grid = doc.operations[0].feasible_grid
    assert grid.infeasible_points == 0 and grid.cam_infeasible_points >= 10
    assert all(v == 0 for v in checked.counts.values())


def test_every_written_contact_pose_is_feasible_by_another_judge(reoriented):
    checked, _ = reoriented
    plan = checked.program.fives[0]
    job = checked.job
    gjk = PoseJudge(job.index, checked.cutters[0], float(checked.document.operations[0].tolerance),
                    job.triangles.deviation, depths=gjk_pose_depths)
    assert gjk(plan.contacts.cc, plan.contacts.normal, plan.chosen.axis).all()
    assert not gjk(plan.contacts.cc, plan.contacts.normal, plan.cam_axis).all()
    sol = job.motion.chain.solve(plan.chosen.axis)
    assert sol.reach.max() <= 1e-6
    assert sol.pole.min() > job.cfg.five_axis.singular_cone_deg
    # the written tips touch the contacts at the chosen axes (a ball: centre r along the
    # normal), to the CL file's 4 decimals (the CAM tip's offset from its touching tip is kept)
    tips = checked.program.tip[plan.rows]
    np.testing.assert_allclose(tips + 3.0 * plan.chosen.axis, plan.contacts.cc
                               + 3.0 * plan.contacts.normal, atol=1e-4)


def test_the_document_carries_lead_tilt_and_the_feasible_sets(reoriented):
    checked, _ = reoriented
    doc, plan = checked.document, checked.program.fives[0]
    grid = doc.operations[0].feasible_grid
    nl, nt = len(grid.leads), len(grid.tilts)
    np.testing.assert_allclose(np.radians(grid.leads), plan.region.leads, atol=1e-9)
    first = {}
    for p in doc.points:
        if p.kind == "cl" and p.lead is not None:
            first.setdefault(p.move, p)
    assert sorted(first) == plan.rows.tolist()
    pts = [first[r] for r in plan.rows.tolist()]
    lead = np.radians([p.lead for p in pts])
    tilt = np.radians([p.tilt for p in pts])
    np.testing.assert_allclose(axes_from_angles(plan.frames, lead, tilt),
                               np.array([p.axis for p in pts]), atol=1e-9)
    masks = np.array([np.unpackbits(np.frombuffer(base64.b64decode(p.feasible_mask), np.uint8),
                                    count=nl * nt) for p in pts]).reshape(-1, nl, nt)
    np.testing.assert_array_equal(masks, plan.region.mask)
    # the CAM's axis is the hub normal, the grid's (lead 0, tilt 0): its bit is its verdict
    i0, j0 = grid.leads.index(0.0), grid.tilts.index(0.0)
    np.testing.assert_array_equal(masks[:, i0, j0].astype(bool), plan.cam_feasible)
    assert all(p.feasible_crossings > 0 for p in pts)


def test_the_posted_program_reads_back_as_written_and_checks_clean(reoriented, job):
    checked, program = reoriented
    mach = load_machine("linuxcnc-xyzac-trt")
    text = program.read_text()
    assert "M428" in text and " A" in text and " C" in text and "M1\n" not in text
    moves = read_gcode(program, mach.dialect, units=mach.units)
    pm = part_motions(moves, mach)
    ok = pm.known & pm.end
    tip = checked.program.tip
    axis = checked.program.axis / np.linalg.norm(checked.program.axis, axis=1)[:, None]
    d, i = cKDTree(pm.tip[ok]).query(tip)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", pm.axis[ok][i], axis), -1.0, 1.0))
    assert d.max() <= ROUND_TRIP and ang.max() <= ROUND_TRIP
    cutter = read_cl(job).operations[0].cutter
    tp = toolpath_of(pm, path=program, units="mm", cutter=cutter)
    again = check_toolpath(tp, job.with_suffix(".json"), CheckOptions(cutter=cutter, machine=mach))
    assert again.summary.status == "ok" and findings_in(again.summary.counts) == 0


def test_the_planner_moves_the_rotary_axes_less_than_the_greedy_smoothing(reoriented):
    from benchmarks.bench_posture import compare

    rows = {name: (m, ok) for name, m, ok in compare(reoriented[0])}
    ours, ours_ok = rows["shortest path + MB-spline (written)"]
    greedy, greedy_ok = rows["greedy smoothing (Jun, Lee and Cha)"]
    assert ours_ok and greedy_ok and not rows["CAM (hub normal)"][1]
    assert ours.total_motion_deg <= greedy.total_motion_deg
    assert ours.peak_acceleration_deg_per_mm2 <= greedy.peak_acceleration_deg_per_mm2
    assert ours.peak_velocity_deg_per_mm <= greedy.peak_velocity_deg_per_mm


def test_least_rotation_takes_a_to_b_about_their_normal():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(50, 3))
    b = rng.normal(size=(50, 3))
    a /= np.linalg.norm(a, axis=1)[:, None]
    b /= np.linalg.norm(b, axis=1)[:, None]
    np.testing.assert_allclose(least_rotation(a, b, a), b, atol=1e-12)
    k = np.cross(a, b)
    np.testing.assert_allclose(least_rotation(a, b, k), k, atol=1e-12)  # the axis stays
    v = rng.normal(size=(50, 3))
    np.testing.assert_allclose(np.linalg.norm(least_rotation(a, b, v), axis=1),
                               np.linalg.norm(v, axis=1), atol=1e-12)
    np.testing.assert_allclose(least_rotation(a, a, v), v, atol=1e-12)


def test_the_trunnion_reaches_its_limits_and_avoids_its_pole():
    chain = Chain(load_machine("linuxcnc-xyzac-trt"))  # A in [-100, 50] about X, C about Z
    reach = machine_reach(chain, cone=5.0)
    deg = np.array([0.0, 4.0, 6.0, 50.0, 99.0, 101.0, 150.0])
    t = np.radians(deg)
    axes = np.column_stack([np.sin(t), np.zeros_like(t), np.cos(t)])
    # the angle from +Z is |A|: the pole cone (5 deg) out, A down to -100 deg in
    np.testing.assert_array_equal(reach(axes), [False, False, True, True, True, False, False])


def test_segments_and_feed_directions():
    rows = np.array([3, 4, 5, 9, 10, 20])
    starts = contact_segments(rows)
    np.testing.assert_array_equal(starts, [True, False, False, True, False, True])
    cc = np.array([[0, 0, 0], [1, 0, 0], [3, 0, 0], [0, 5, 0], [0, 7, 0], [9, 9, 9]], float)
    f = feed_directions(cc, starts)
    np.testing.assert_allclose(f[:5], [[1, 0, 0], [2, 0, 0], [2, 0, 0], [0, 2, 0], [0, 2, 0]])
    np.testing.assert_allclose(f[5], [1, 0, 0])  # a lone point
    assert math.isclose(np.linalg.norm(f[1]), 2.0)
