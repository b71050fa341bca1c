"""The pieces of the verdict rule: canned cycles as the machine runs them, tolerances from the
job, the one verdict function, NURBS parts as triangles within their deviation, and the part
transform."""

from __future__ import annotations

import numpy as np
import pytest

from checker.apt import read_cl_text
from checker.config import default_config
from checker.errors import PathcheckError
from checker.geometry import find_part_beside
from checker.geometry.primitives import nurbs_cylinder, nurbs_sphere
from checker.geometry.tessellate import part_triangles
from checker.geometry.transform import parse_transform, rotation_xyz, transform_part
from checker.moves import FEED, RAPID, START, machine_moves
from checker.part import MeshPart, Part
from checker.tolerance import operation_tolerances
from checker.verdict import BODY, HOLDER, SHANK, decide, status

DRILL = """PARTNO/HOLES
UNITS/MM
CUTTER/6.5,0,3.25,1.952797,31.,0,105.
LOAD/TOOL,1
RAPID/
GOTO/10,20,100
CYCLE/INIT
CYCLE/DRILL,FEDTO,7.5,MMPM,120,RAPTO,3.,RTRCTO,25.,DWELL,0
GOTO/10,20,0
GOTO/40,20,-2
CUTTER/10
LOAD/TOOL,2
RAPID/
GOTO/0,0,50
FEDRAT/300,MMPM
GOTO/0,0,-1
FINI
"""


def test_canned_cycle_becomes_its_moves():
    """Each hole: over it at the height the tool arrives at, rapid to 3 above, feed to 7.5
    below, rapid back to 25 above; the next hole is reached at the retract plane; a FEDRAT
    ends the cycle (SolidWorks CAM writes no CYCLE/OFF); a new operation starts afresh."""
    tp = read_cl_text(DRILL, path="holes.apt")
    m = tp.motion_arrays()
    np.testing.assert_allclose(m.cycle_geometry[1], [7.5, 3.0, 25.0])
    # the cycle stays on through the tool change (the next drill repeats it) until a FEDRAT;
    # rapid positions inside it are not holes
    assert m.cycle.tolist() == [False, True, True, True, False]
    mv = machine_moves(m)
    z = mv.tip[:, 2]
    np.testing.assert_allclose(z, [100, 100, 3, -7.5, 25, 25, 1, -9.5, 23, 50, -1])
    np.testing.assert_allclose(mv.tip[5, :2], [40, 20])
    assert mv.kind.tolist() == [START, RAPID, RAPID, FEED, RAPID, RAPID, RAPID, FEED, RAPID,
                                START, FEED]
    assert mv.hole.sum() == 8


def test_positional_iso_cycle_and_missing_depth():
    tp = read_cl_text("CUTTER/6\nRAPID\nGOTO/0,0,10\nCYCLE/DRILL,12,MMPM,100,2\nGOTO/0,0,0\n"
                      "CYCLE/OFF\nFINI\n", path="iso.apt")
    np.testing.assert_allclose(tp.motion_arrays().cycle_geometry[1], [12.0, 2.0, 2.0])
    with pytest.raises(PathcheckError, match=r"bad.apt:4: CYCLE/: expected the cycle's depth"):
        read_cl_text("CUTTER/6\nRAPID\nGOTO/0,0,10\nCYCLE/DRILL,MMPM\nGOTO/0,0,0\nFINI\n",
                     path="bad.apt")


def test_tolerance_per_operation():
    text = ("CUTTER/10\nINTOL/0.005\nFEDRAT/100\nGOTO/0,0,0\nGOTO/1,0,0\nCUTTER/6\nLOAD/TOOL,2\n"
            "THICK/-0.1\nFEDRAT/100\nGOTO/0,0,0\nGOTO/2,0,0\nFINI\n")
    tp = read_cl_text(text, path="tol.apt")
    tol = operation_tolerances(tp, default=0.02, part_deviation=0.003, arc_chord=0.01)
    ops = [o for o in tp.operations if o.end_motion > o.first_motion]
    assert len(ops) == 2
    # INTOL stays in effect; the second operation also cuts 0.1 into the part on purpose; the
    # part's deviation is not in it (it is added near each pose), nor the arcs' chord error in
    # operations without arcs
    np.testing.assert_allclose(tol.value[[tp.operations.index(o) for o in ops]],
                               [0.005, 0.005 + 0.1])
    tp2 = read_cl_text("CUTTER/10\nFEDRAT/100\nGOTO/0,0,0\nGOTO/1,0,0\nFINI\n", path="x.apt")
    t2 = operation_tolerances(tp2, default=0.02, part_deviation=0.0, arc_chord=0.0)
    assert t2.value.max() == pytest.approx(0.02) and "config" in t2.source


def test_arc_chord_allowance_only_where_there_are_arcs():
    """The chord error of arcs sampled into straight moves widens the tolerance of the
    operations that have an arc, and of no other."""
    text = ("CUTTER/10\nINTOL/0.01\nFEDRAT/100\nGOTO/10,0,0\n"
            "CIRCLE/0,0,0,0,0,1\nGOTO/0,10,0\nCUTTER/6\nLOAD/TOOL,2\nFEDRAT/100\nGOTO/0,0,0\nGOTO/2,0,0\nFINI\n")
    tp = read_cl_text(text, path="arcs.apt")
    assert len(tp.arcs) == 1
    tol = operation_tolerances(tp, default=0.02, part_deviation=0.0, arc_chord=0.01)
    ops = [o for o in tp.operations if o.end_motion > o.first_motion]
    np.testing.assert_allclose(tol.value[[tp.operations.index(o) for o in ops]],
                               [0.01 + 0.01, 0.01])


def test_decide_is_the_one_rule():
    depth = np.array([-1.0, 0.01, 0.05, 0.05, 0.05, 0.05, 0.0, 0.05])
    piece = np.array([BODY, BODY, BODY, BODY, SHANK, HOLDER, BODY, BODY])
    rapid = np.array([False] * 7 + [True])
    near = np.array([True, True, True, False, True, True, True, True])
    inacc = np.array([True, False, False, False, False, False, True, False])
    v = decide(depth, piece, rapid, near, 0.02, inacc)
    assert v.tolist() == ["inaccessible", "within_tolerance", "gouge", "interference", "holder",
                          "holder", "inaccessible", "crash"]
    assert status(v) == "findings" and status(v[:2]) == "ok"


@pytest.mark.parametrize("deviation", [0.01, 0.002])
def test_nurbs_triangles_stay_within_their_deviation(deviation):
    """A sphere R 20 and a cylinder R 15: every vertex on the surface, and the triangles'
    worst distance (at edge midpoints and centroids) from the true surface within the target:
    the analytic distance of those probes from the sphere / cylinder is checked too."""
    cfg = default_config().geometry
    for surf, dist in ((nurbs_sphere(20.0), lambda p: 20.0 - np.linalg.norm(p, axis=1)),
                       (nurbs_cylinder(15.0, 0.0, 40.0),
                        lambda p: 15.0 - np.hypot(p[:, 0], p[:, 1]))):
        tris = part_triangles(Part([surf]), deviation, cfg)
        assert np.abs(dist(tris.vertices)).max() < 1e-9
        v, t = tris.vertices, tris.triangles
        mids = np.concatenate([0.5 * (v[t[:, 0]] + v[t[:, 1]]), v[t].mean(axis=1)])
        sag = dist(mids)
        assert sag.max() <= tris.typical + 1e-9 and tris.typical <= deviation
        assert sag.min() > -1e-9  # chords of a convex surface lie inside it
        # normals by the right-hand rule point out of the solid, as the surface's do
        n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
        radial = v[t].mean(axis=1) * ([1, 1, 0] if surf.name == "cylinder" else 1)
        real = np.linalg.norm(n, axis=1) > 1e-12  # the poles' cells are slivers
        assert (np.einsum("ij,ij->i", n, radial)[real] > 0).all()


def test_part_transform_parses_and_moves_a_part():
    R, t = parse_transform("0,0,90,1,2,3")
    np.testing.assert_allclose(R @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(t, [1, 2, 3])
    R2, t2 = parse_transform("0,-1,0,5, 1,0,0,0, 0,0,1,0")
    np.testing.assert_allclose(R2, rotation_xyz(0, 0, 90), atol=1e-12)
    np.testing.assert_allclose(t2, [5, 0, 0])
    for bad in ("1,2,3", "2,0,0,0,0,1,0,0,0,0,1,0", "a,b,c,d,e,f"):
        with pytest.raises(PathcheckError, match="--part-transform"):
            parse_transform(bad)
    mesh = MeshPart(np.eye(3), np.array([[0, 1, 2]]), np.array([[1.0, 1, 1]]) / np.sqrt(3))
    moved = transform_part(Part([], mesh=mesh), R, t)
    np.testing.assert_allclose(moved.mesh.vertices, np.eye(3) @ R.T + t)
    np.testing.assert_allclose(moved.mesh.normals, mesh.normals @ R.T)
    assert moved.content_hash != Part([], mesh=mesh).content_hash


def test_part_beside_the_job_in_any_case(tmp_path):
    (tmp_path / "JOB.apt").write_text("")
    (tmp_path / "JOB.STL").write_text("")
    assert find_part_beside(tmp_path / "JOB.apt") == tmp_path / "JOB.STL"
