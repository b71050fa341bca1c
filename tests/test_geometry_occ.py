"""STEP and IGES parts through OpenCASCADE: every face loads, and pathcheck's evaluation, normals
and trims agree with OpenCASCADE's own (BRep_Tool surfaces, face classifier)."""

from __future__ import annotations

import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.BRepGProp import BRepGProp_Face
from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
from OCP.gp import gp_Pnt, gp_Vec
from OCP.IGESControl import IGESControl_Reader
from OCP.STEPControl import STEPControl_Reader
from OCP.TopAbs import TopAbs_FACE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS

from checker.geometry import load_part
from checker.geometry.evaluate import evaluate
from checker.geometry.part_info import describe_part, format_part_info
from checker.geometry.sampling import sample_part


def _occ_faces(path):
    reader = STEPControl_Reader() if path.suffix in (".stp", ".step") else IGESControl_Reader()
    reader.ReadFile(str(path))
    reader.TransferRoots()
    ex, faces = TopExp_Explorer(reader.OneShape(), TopAbs_FACE), []
    while ex.More():
        faces.append(TopoDS.Face(ex.Current()))
        ex.Next()
    return faces


@pytest.fixture(scope="module")
def turbine(realdata):
    path = realdata / "occt-cad-nurbs" / "ec_turbine-A.stp"
    return path, load_part(path), _occ_faces(path)


def test_turbine_has_all_53_faces_31_rational_bsplines(turbine):
    _, part, faces = turbine
    assert len(part.surfaces) == len(faces) == 53
    kinds = [s.kind for s in part.surfaces]
    assert kinds.count("nurbs") == 31 and all(s.rational for s in part.surfaces[:0])
    assert sum(s.rational for s in part.surfaces if s.kind == "nurbs") == 31
    assert {k: kinds.count(k) for k in ("cylinder", "cone", "plane", "sphere", "torus")} == {
        "cylinder": 10, "cone": 5, "plane": 5, "sphere": 1, "torus": 1,
    }  # fmt: skip


def test_turbine_points_and_derivatives_match_opencascade(turbine):
    _, part, faces = turbine
    rng = np.random.default_rng(0)
    worst_point, worst_du, worst_analytic = 0.0, 0.0, 0.0
    for s, face in zip(part.surfaces, faces, strict=True):
        geom = BRep_Tool.Surface_s(face)
        (u0, u1), (v0, v1) = s.domain
        u, v = rng.uniform(u0, u1, 12), rng.uniform(v0, v1, 12)
        ev = evaluate(s, u, v)
        for k in range(len(u)):
            if s.kind == "nurbs":  # same parameters as OCC's surface: compare D1 directly
                p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
                geom.D1(u[k], v[k], p, du, dv)
                worst_point = max(worst_point, np.abs(ev.points[k] - p.Coord()).max())
                rel = np.abs(ev.du[k] - du.Coord()).max() / max(1.0, np.linalg.norm(du.Coord()))
                worst_du = max(worst_du, rel)
            else:  # converted exactly: the point must lie on OCC's analytic surface
                proj = GeomAPI_ProjectPointOnSurf(gp_Pnt(*ev.points[k]), geom)
                worst_analytic = max(worst_analytic, proj.LowerDistance())
    assert worst_point < 1e-9 and worst_du < 1e-9 and worst_analytic < 1e-9


def test_turbine_normals_follow_face_orientation(turbine):
    _, part, faces = turbine
    tp = sample_part(part)
    rng = np.random.default_rng(1)
    checked = 0
    for s, face in zip(part.surfaces, faces, strict=True):
        if s.kind != "nurbs":
            continue
        sel = rng.choice(np.flatnonzero(tp.surface == s.id), 5)
        prop = BRepGProp_Face(face)
        for i in sel:
            p, n = gp_Pnt(), gp_Vec()
            prop.Normal(float(tp.uv[i, 0]), float(tp.uv[i, 1]), p, n)
            occ_n = np.array(n.Coord()) / n.Magnitude()
            assert np.dot(occ_n, tp.normals[i]) > 1 - 1e-9
            checked += 1
    assert checked == 31 * 5


def _distance_to_face(face, point) -> float:
    """OCC's exact 3-D distance (mm) from a point to the trimmed face."""
    vertex = BRepBuilderAPI_MakeVertex(gp_Pnt(*point)).Vertex()
    return BRepExtrema_DistShapeShape(vertex, face).Value()


@pytest.mark.parametrize("name", ["ec_turbine-A.stp", "occ22470.igs"])
def test_trimmed_faces_agree_with_opencascade(realdata, name):
    """Test points of trimmed faces lie on OCC's trimmed face (within the 1 um trim polyline
    tolerance), and random surface points that pathcheck trims away lie off it."""
    path = realdata / "occt-cad-nurbs" / name
    part, faces = load_part(path), _occ_faces(path)
    tp = sample_part(part)
    rng = np.random.default_rng(2)
    trimmed = [s for s in part.surfaces if s.trim is not None]
    assert len(trimmed) >= 10
    n_out = 0
    for s in trimmed:
        face = faces[s.id]
        mine = tp.points[tp.surface == s.id]
        for p in mine[rng.choice(len(mine), 8)]:
            assert _distance_to_face(face, p) < 2e-3
        (u0, u1), (v0, v1) = s.domain
        u, v = rng.uniform(u0, u1, 100), rng.uniform(v0, v1, 100)
        keep = s.trim.contains(u, v)
        gone = evaluate(s, u[~keep], v[~keep]).points
        far = tp.tree.query(gone)[0] > 0.5  # clear of the boundary by a sampling cell
        for p in gone[far][:8]:
            assert _distance_to_face(face, p) > 0.1
            n_out += 1
    assert n_out >= 40


@pytest.mark.parametrize(
    ("folder", "name", "faces", "shape"),
    [
        ("occt-cad-nurbs", "PRO20359-L1.igs", 1, (5, 5, 41, 25)),
        ("occt-cad-nurbs", "PRO20359-L2.igs", 1, (5, 5, 29, 16)),
        ("occt-cad-nurbs", "PRO20359-L4.igs", 1, (5, 5, 65, 11)),
        ("occt-cad-nurbs", "PRO20359-L5.igs", 1, (5, 5, 41, 19)),
        ("occt-cad-nurbs", "occ22470.igs", 18, None),
        ("occt-cad-nurbs", "hammer.iges", 45, None),
        ("bladex-propeller-iges", "upper.iges", 1, (3, 2, 526, 13)),
        ("bladex-propeller-iges", "lower.iges", 1, None),
        ("bladex-propeller-iges", "tip.iges", 1, None),
        ("bladex-propeller-iges", "root.iges", 1, None),
    ],
)
def test_iges_files_load_exactly(realdata, folder, name, faces, shape):
    path = realdata / folder / name
    part = load_part(path)
    assert len(part.surfaces) == faces
    s = part.surfaces[0]
    if shape is not None:
        assert (s.degree_u, s.degree_v, *s.ctrlpts.shape[:2]) == shape
    occ = BRep_Tool.Surface_s(_occ_faces(path)[0])
    (u0, u1), (v0, v1) = s.domain
    rng = np.random.default_rng(3)
    u, v = rng.uniform(u0, u1, 20), rng.uniform(v0, v1, 20)
    got = evaluate(s, u, v).points
    want = np.array([occ.Value(a, b).Coord() for a, b in zip(u, v, strict=True)])
    assert np.abs(got - want).max() < 1e-9


def test_plate_with_hole_step_roundtrip(tmp_path):
    """A STEP plate with a drilled hole: the top face's plane extends over the hole; no test
    point may come from there, and the hole wall is a bore (normals towards the axis)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    box = BRepPrimAPI_MakeBox(gp_Pnt(-30, -30, -10), 60.0, 60.0, 10.0).Shape()
    drill = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(0, 0, -20), gp_Dir(0, 0, 1)), 8.0, 40.0)
    plate = BRepAlgoAPI_Cut(box, drill.Shape()).Shape()
    writer = STEPControl_Writer()
    writer.Transfer(plate, STEPControl_AsIs)
    path = tmp_path / "plate.step"
    writer.Write(str(path))
    part = load_part(path)
    assert len(part.surfaces) == 7
    assert np.allclose(part.bbox, [[-30, -30, -10], [30, 30, 0]], atol=1e-7)
    tp = sample_part(part)
    r = np.hypot(tp.points[:, 0], tp.points[:, 1])
    assert r.min() > 8.0 - 1e-3  # trims are honoured to the 1 um trim polyline tolerance
    bore = [s.id for s in part.surfaces if s.kind == "cylinder"]
    wall = np.isin(tp.surface, bore)
    assert np.allclose(r[wall], 8.0, atol=1e-9)
    assert wall.sum() > 100
    radial = tp.points[wall, :2] / r[wall, None]
    assert np.allclose(tp.normals[wall, :2], -radial, atol=1e-9)
    top_id = [s.id for s in part.surfaces if s.kind == "plane" and s.ctrlpts[..., 2].min() > -1e-9]
    top = tp.surface == top_id[0]
    assert len(top_id) == 1 and part.surfaces[top_id[0]].trim is not None
    assert np.allclose(tp.normals[top], [0, 0, 1], atol=1e-12)
    assert np.sum(top & (r < 8.5)) > 50  # the rim of the hole is sampled


def test_describe_turbine(turbine):
    path, _, _ = turbine
    d = describe_part(path)
    assert d["faces"] == 53 and d["units"] == "mm" and len(d["surfaces"]) == 53
    assert sum(s["rational"] and s["kind"] == "nurbs" for s in d["surfaces"]) == 31
    assert np.allclose(d["bbox"]["min"][0], -32.0, atol=1e-6)
    text = format_part_info(d)
    assert "53 faces" in text and "face_52" in text


def test_step_without_faces_is_a_part_error(tmp_path):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    from checker.errors import PathcheckError

    writer = STEPControl_Writer()
    writer.Transfer(
        BRepBuilderAPI_MakeEdge(gp_Pnt(0, 0, 0), gp_Pnt(10, 0, 0)).Edge(), STEPControl_AsIs
    )
    path = tmp_path / "wire.stp"
    writer.Write(str(path))
    with pytest.raises(PathcheckError, match="no surface found") as err:
        load_part(path)
    assert err.value.code == "part" and "wire.stp" in str(err.value)


def test_inch_step_is_read_in_mm(tmp_path):
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    writer = STEPControl_Writer()
    Interface_Static.SetCVal_s("write.step.unit", "INCH")
    try:
        writer.Transfer(
            BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), 25.4, 50.8, 10.0).Shape(), STEPControl_AsIs
        )
        path = tmp_path / "box_inch.step"
        writer.Write(str(path))
    finally:
        Interface_Static.SetCVal_s("write.step.unit", "MM")
    assert "CONVERSION_BASED_UNIT('INCH'" in path.read_text()
    part = load_part(path)
    assert part.units == "mm" and np.allclose(part.bbox, [[0, 0, 0], [25.4, 50.8, 10.0]], atol=1e-9)
