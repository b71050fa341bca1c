"""`pathcheck JOB.apt --reorient --strategy contact-order` (`checker.five_axis.contact_plan`,
issue #21): flat-end (CUTTER/10) and bull-nose (CUTTER/16,3) finishing across the torus trough
of tests/test_contact_order.py (exact rational NURBS; fed along the tube's meridian, which is
more concave, 1/25 mm, than the section across the feed, 1/85 mm), three zig-zag passes per
cutter on the 5-axis trunnion linuxcnc-xyzac-trt. The CAM leans the tool by a lead too small
for the meridian (10 and 6 degrees: the heel digs in 2R behind the contact, MATH §11.4) and
writes its contact points as NX does (`$$ cx,cy,cz`), so CL -> CC starts at them and the poses
that gouge behind are still contact rows. Re-oriented: no finding left, every contact pose is
the pose of Liu et al. (n.d.) (its lead raised by the judge and the machine's reach) or its fairing,
accepted by an independent judge; the flat end's strip is wider than a ball's; the posted program
reads back within 1e-4; a ball cutter is a one-line usage error (exit 2)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from mesh_gjk_oracle import gjk_pose_depths
from scipy.spatial import cKDTree
from test_contact_order import torus_trough

from checker.apt import read_cl
from checker.check import check_program
from checker.check.options import CheckOptions
from checker.check.posting import post_checked
from checker.cli import main
from checker.cutter import parse_cutter
from checker.five_axis.contact_order import contact_order_axes
from checker.five_axis.lead_tilt import axes_from_angles, local_frames
from checker.five_axis.poses import PoseJudge
from checker.five_axis.reorient import feed_directions, machine_reach
from checker.geometry.evaluate import evaluate
from checker.postproc.machine import load_machine
from checker.postproc.reader import read_gcode
from checker.postproc.replay import part_motions
from checker.results import findings_in

MACHINE = "linuxcnc-xyzac-trt"
CUTTERS = (("CUTTER/10", 10.0), ("CUTTER/16,3", 6.0))  # the CAM's leads, degrees: too small
ROUND_TRIP = 1e-4  # mm and rad


def _write_part(path) -> None:
    """The torus trough as geomdl exchange JSON (`reversed`: its normals towards the tube's
    axis)."""
    s = torus_trough().surfaces[0]
    nu, nv, _ = s.ctrlpts.shape
    d = {"type": "spline", "rational": True, "dimension": 3, "degree_u": s.degree_u,
         "degree_v": s.degree_v, "knotvector_u": s.knots_u.tolist(),
         "knotvector_v": s.knots_v.tolist(), "size_u": nu, "size_v": nv,
         "control_points": {"points": s.ctrlpts.reshape(-1, 3).tolist(),
                            "weights": s.weights.ravel().tolist()},
         "name": "trough", "reversed": int(bool(s.flip))}
    path.write_text(json.dumps({"shape": {"type": "surface", "count": 1, "data": [d]}}))


def _f(v, digits: int) -> str:
    return ",".join(f"{x:.{digits}f}" for x in v)


def _write_job(path) -> None:
    """Per cutter three passes along the meridian (v from 0.3 to 0.7, 11 contacts, at u = 0.42,
    0.5, 0.58, the middle one reversed): the tool at the CAM's lead touching each contact,
    approach and retract along the axis."""
    s = torus_trough().surfaces[0]
    lines = ["PARTNO/TORUS TROUGH FINISH", f"PPRINT/MACHINE {MACHINE}", "UNITS/MM", "MULTAX"]
    for k, (text, lead) in enumerate(CUTTERS):
        c = parse_cutter(text)
        lines += [text, f"LOADTL/{k + 1}", "SPINDL/12000,RPM,CLW"]
        for p, u in enumerate((0.42, 0.5, 0.58)):
            v = np.linspace(0.3, 0.7, 11)[::-1 if p % 2 else 1]
            ev = evaluate(s, np.full(len(v), u), v)
            fr = local_frames(ev.normals, ev.dv * (-1 if p % 2 else 1))
            ax = axes_from_angles(fr, np.full(len(v), math.radians(lead)), np.zeros(len(v)))
            tip = c.tip_from_contact(ev.points, ev.normals, ax)
            lines += ["RAPID", f"GOTO/{_f(tip[0] + 30 * ax[0], 4)},{_f(ax[0], 7)}",
                      "FEDRAT/250.0,MMPM", f"GOTO/{_f(tip[0] + 3 * ax[0], 4)},{_f(ax[0], 7)}",
                      "FEDRAT/800.0,MMPM"]
            lines += [f"GOTO/{_f(t, 4)},{_f(a, 7)} $$ {_f(q, 4)}"
                      for t, a, q in zip(tip, ax, ev.points, strict=True)]
            lines += [f"GOTO/{_f(tip[-1] + 3 * ax[-1], 4)},{_f(ax[-1], 7)}", "RAPID",
                      f"GOTO/{_f(tip[-1] + 30 * ax[-1], 4)},{_f(ax[-1], 7)}"]
    path.write_text("\n".join([*lines, "END", "FINI"]) + "\n")


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    folder = tmp_path_factory.mktemp("trough")
    _write_part(folder / "trough.json")
    _write_job(folder / "trough.apt")
    return folder / "trough.apt"


@pytest.fixture(scope="module")
def reoriented(job):
    """The job checked with --reorient --strategy contact-order and posted."""
    out = job.with_suffix(".nc")
    checked = check_program(read_cl(job), options=CheckOptions(
        reorient=True, strategy="contact-order", output=out))
    post_checked(checked, out, "refuse")
    return checked, out


def test_the_findings_at_the_cam_axes_are_gone(reoriented):
    checked, _ = reoriented
    doc = checked.document
    assert findings_in(doc.summary.counts_cam) >= 100  # the heels, both cutters
    assert findings_in(doc.summary.counts) == 0 and doc.summary.status == "ok"
    assert all(v == 0 for v in checked.counts.values())
    for op in doc.operations:
        assert op.axis_class == "multi-axis" and op.handling == "re-oriented"
        assert findings_in(op.counts_cam) > 0 and findings_in(op.counts) == 0
        co = op.contact_order
        assert op.feasible_grid is None and co is not None
        assert co.method == "contact order (Liu et al.), then MB-spline fairing"
        assert co.infeasible_points == 0 and co.cam_infeasible_points == co.points
        assert co.points >= 25 and co.raised_points >= 0.9 * co.points
        assert co.order == [0, 0, 0, co.points]  # third order everywhere
        # the flat end's strip against a ball of the same diameter (0.65..0.84 mm)
        assert co.width_min > 5.0 * co.ball_width_max


def test_every_axis_is_the_contact_order_pose_or_its_fairing(reoriented):
    """contact_order_axes again, with a judge and a reach made here: the planned posture is its
    pose at every contact row; the written (faired) axis is that pose where the fairing left it
    (the segments' ends at least) and elsewhere near it, accepted by an independent judge (GJK
    depths) and reachable away from the machine's pole."""
    checked, _ = reoriented
    job = checked.job
    chain = job.motion.chain
    reach = machine_reach(chain, cone=job.cfg.five_axis.singular_cone_deg)
    for o, plan in checked.program.fives.items():
        cutter = checked.cutters[o]
        tol = float(checked.document.operations[o].tolerance)
        judge = PoseJudge(job.index, cutter, tol, job.triangles.deviation)
        con = plan.contacts
        feeds = feed_directions(con.cc, plan.starts)

        def accepted(cc, normals, axes, judge=judge):
            ok = reach(axes)
            ok[ok] = judge(cc[ok], normals[ok], axes[ok])
            return ok

        want = contact_order_axes(job.part, cutter, con.cc, con.normal, feeds, con.surface,
                                  con.uv, judge=accepted, scallop=0.01,
                                  max_lead=math.radians(60.0))
        assert want.found.all()
        np.testing.assert_allclose(plan.planned.axis, want.axes, atol=1e-12)
        # the reach counts: where the reversed pass leans the axis onto the C axis (within the
        # 5-degree pole cone) the lead is raised further than the judge alone raises it
        alone = contact_order_axes(job.part, cutter, con.cc, con.normal, feeds, con.surface,
                                   con.uv, judge=judge, scallop=0.01,
                                   max_lead=math.radians(60.0))
        assert (alone.raised <= want.raised).all() and (alone.raised < want.raised).any()
        kept = np.abs(plan.chosen.axis - want.axes).max(axis=1) <= 1e-7
        ends = plan.starts | np.r_[plan.starts[1:], True]
        assert kept[ends].all() and (~kept).any()
        np.testing.assert_allclose(plan.lead[kept], want.lead[kept], atol=1e-6)
        np.testing.assert_allclose(plan.tilt[kept], want.tilt[kept], atol=1e-6)
        # the fairing moves an axis less than the largest turn between consecutive poses of
        # the contact-order pose (Liu et al.) in its segment
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", plan.chosen.axis, want.axes), -1, 1))
        step = np.arccos(np.clip(np.einsum("ij,ij->i", want.axes[1:], want.axes[:-1]), -1, 1))
        segment = np.cumsum(plan.starts)
        largest = np.zeros(segment.max() + 1)
        np.maximum.at(largest, segment[1:][~plan.starts[1:]], step[~plan.starts[1:]])
        assert (turn <= largest[segment] + 1e-7).all() and turn.max() > 1e-3
        gjk = PoseJudge(job.index, cutter, tol, job.triangles.deviation,
                        depths=gjk_pose_depths)
        assert gjk(con.cc, con.normal, plan.chosen.axis).all()
        assert not gjk(con.cc, con.normal, plan.cam_axis).any()
        sol = chain.solve(plan.chosen.axis)
        assert sol.reach.max() <= 1e-6 and sol.pole.min() > job.cfg.five_axis.singular_cone_deg
        # the document's lead and tilt are the written axes'
        first = {}
        for p in checked.document.points:
            if p.kind == "cl" and p.op == o and p.lead is not None:
                first.setdefault(p.move, p)
        assert sorted(first) == plan.rows.tolist()
        assert all(first[r].feasible_mask is None for r in first)
        np.testing.assert_allclose([first[r].lead for r in plan.rows.tolist()],
                                   np.degrees(plan.lead), atol=1e-9)


def test_the_posted_program_reads_back_as_written(reoriented):
    """Every written pose (both tools) is a pose of the posted program read back through the
    machine's kinematics, within 1e-4 mm and rad."""
    checked, program = reoriented
    mach = load_machine(MACHINE)
    text = program.read_text()
    assert "M428" in text and " A" in text and " C" in text and "T2" in text
    pm = part_motions(read_gcode(program, mach.dialect, units=mach.units), mach)
    ok = pm.known & pm.end
    axis = checked.program.axis / np.linalg.norm(checked.program.axis, axis=1)[:, None]
    d, i = cKDTree(pm.tip[ok]).query(checked.program.tip)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", pm.axis[ok][i], axis), -1.0, 1.0))
    assert d.max() <= ROUND_TRIP and ang.max() <= ROUND_TRIP


def test_a_ball_cutter_is_a_usage_error(job, capsys):
    """A ball with contact-order, and contact-order without --reorient: one line, exit 2."""
    for args, says in ((["--reorient", "--strategy", "contact-order", "--cutter", "CUTTER/10,5"],
                        "positions flat-end and bull-nose cutters"),
                       (["--strategy", "contact-order"], "add --reorient")):
        with pytest.raises(SystemExit) as exit_:
            main([str(job), "--no-store", *args])
        assert exit_.value.code == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and says in err and "contact-order" in err
