"""OpenCASCADE (OCP) on its own, for tests that judge pathcheck's STEP/IGES parts from outside:
read the file, list its faces (in `TopExp_Explorer` order, the order in which
`checker.geometry.occ_io` numbers its surfaces), sample each face inside its trim by OCC's 2-D
classifier (`BRepClass_FaceClassifier`), measure the distance from points to a face
(`BRepExtrema_DistShapeShape`, trims included), and mesh the part (`BRepMesh_IncrementalMesh`).
Nothing here uses pathcheck's own reader, evaluator or trims. Part frame, mm.

Sampling a face (`sample_face`): a grid over the face's (u, v) bounds whose spacing is about
`spacing` mm on the surface (the mean lengths of its iso-lines), every node classified, plus
points along each edge of every wire: the edge's pcurve at about `spacing / 2` mm apart, moved
into the face by `inset` mm (in (u, v), along the pcurve's normal scaled by the surface's first
derivatives), kept where the classifier says IN. The edge points find strips along trim edges
much narrower than the grid's spacing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve2d, BRepAdaptor_Surface
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
from OCP.BRepClass import BRepClass_FaceClassifier
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.BRepMesh import BRepMesh_IncrementalMesh
from OCP.BRepTools import BRepTools
from OCP.gp import gp_Pnt, gp_Pnt2d
from OCP.IFSelect import IFSelect_RetDone
from OCP.IGESControl import IGESControl_Reader
from OCP.STEPControl import STEPControl_Reader
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_IN, TopAbs_REVERSED
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS

CAD_SUFFIXES = (".stp", ".step", ".igs", ".iges")
_CLASSIFY_TOL = 1e-9  # (u, v): the classifier's tolerance


def cad_files(root: Path) -> list[Path]:
    """Every STEP/IGES file under `root` (recursive, any case of suffix), sorted."""
    return sorted(p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in CAD_SUFFIXES)


def read_shape(path: Path):
    """The shape of a STEP (.stp, .step) or IGES (.igs, .iges) file; ValueError if unreadable."""
    from OCP.Message import Message, Message_Gravity

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)
    step = Path(path).suffix.lower() in (".stp", ".step")
    reader = STEPControl_Reader() if step else IGESControl_Reader()
    if reader.ReadFile(str(path)) != IFSelect_RetDone or reader.TransferRoots() == 0:
        raise ValueError(f"{path}: OpenCASCADE cannot read it")
    return reader.OneShape()


def faces(shape) -> list:
    """The shape's faces in `TopExp_Explorer` order (pathcheck's surface ids)."""
    ex, out = TopExp_Explorer(shape, TopAbs_FACE), []
    while ex.More():
        out.append(TopoDS.Face(ex.Current()))
        ex.Next()
    return out


@dataclass(frozen=True)
class FaceSamples:
    """Points (N, 3) on one face inside its trim, their (u, v) (N, 2), and which came from
    the edges (`edge` (N,) bool) rather than the interior grid."""

    points: np.ndarray
    uv: np.ndarray
    edge: np.ndarray


def _iso_lengths(surf, u0, u1, v0, v1, n=9) -> tuple[float, float]:
    """Mean 3-D lengths (mm) of n u-iso-lines... the surface's extent along u and along v."""
    us, vs = np.linspace(u0, u1, n), np.linspace(v0, v1, n)
    P = np.array([[surf.Value(a, b).Coord() for b in vs] for a in us])  # (n, n, 3)
    lu = np.linalg.norm(np.diff(P, axis=0), axis=2).sum(axis=0).mean()
    lv = np.linalg.norm(np.diff(P, axis=1), axis=2).sum(axis=1).mean()
    return float(lu), float(lv)


def sample_face(face, spacing: float, inset: float, max_grid: int = 400) -> FaceSamples:
    """Points of `face` inside its trim by OCC's classifier (module docstring): a (u, v) grid
    about `spacing` mm apart (at most `max_grid` nodes a side) and edge points `inset` mm
    inside the face, about `spacing / 2` mm apart along each edge."""
    surf = BRepAdaptor_Surface(face, True)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    lu, lv = _iso_lengths(surf, u0, u1, v0, v1)
    nu = int(np.clip(np.ceil(lu / spacing), 2, max_grid)) + 1
    nv = int(np.clip(np.ceil(lv / spacing), 2, max_grid)) + 1
    # node-centred cells: no node on the bounds (the edges are sampled on their own)
    gu = u0 + (np.arange(nu) + 0.5) * (u1 - u0) / nu
    gv = v0 + (np.arange(nv) + 0.5) * (v1 - v0) / nv
    U, V = np.meshgrid(gu, gv, indexing="ij")
    grid = np.column_stack([U.ravel(), V.ravel()])
    edge_uv = _edge_points(face, surf, spacing / 2.0, inset)
    uv = np.concatenate([grid, edge_uv]) if len(edge_uv) else grid
    is_edge = np.arange(len(uv)) >= len(grid)
    cls = BRepClass_FaceClassifier()
    inside = np.empty(len(uv), dtype=bool)
    for i, (a, b) in enumerate(uv):
        cls.Perform(face, gp_Pnt2d(float(a), float(b)), _CLASSIFY_TOL)
        inside[i] = cls.State() == TopAbs_IN
    uv, is_edge = uv[inside], is_edge[inside]
    pts = np.array([surf.Value(float(a), float(b)).Coord() for a, b in uv]).reshape(-1, 3)
    return FaceSamples(pts, uv, is_edge)


def _edge_points(face, surf, step: float, inset: float) -> np.ndarray:
    """(K, 2) (u, v) points along every edge's pcurve, `inset` mm into the face: the pcurve's
    left normal (the face's material side for a FORWARD edge, by OCC's convention; a REVERSED
    edge is walked backwards, so the normal flips) scaled to `inset` mm on the surface. Both
    sides are tried when the side is in doubt (a seam edge): the classifier keeps the inner."""
    out = []
    ex = TopExp_Explorer(face, TopAbs_EDGE)
    while ex.More():
        edge = TopoDS.Edge(ex.Current())
        ex.Next()
        if BRep_Tool.Degenerated_s(edge):
            continue
        c2d = BRepAdaptor_Curve2d(edge, face)
        t0, t1 = c2d.FirstParameter(), c2d.LastParameter()
        ts = np.linspace(t0, t1, 9)
        pts2 = np.array([c2d.Value(float(t)).Coord() for t in ts])
        xyz = np.array([surf.Value(float(a), float(b)).Coord() for a, b in pts2])
        length = float(np.linalg.norm(np.diff(xyz, axis=0), axis=1).sum())
        n = int(np.clip(np.ceil(length / step), 2, 2000)) + 1
        ts = np.linspace(t0, t1, n)
        sign = -1.0 if edge.Orientation() == TopAbs_REVERSED else 1.0
        for t in ts:
            p, d = gp_Pnt2d(), _vec2d()
            c2d.D1(float(t), p, d)
            a, b = p.X(), p.Y()
            du, dv = _vec3(), _vec3()
            surf.D1(a, b, gp_Pnt(), du, dv)
            su, sv = max(du.Magnitude(), 1e-12), max(dv.Magnitude(), 1e-12)
            nx, ny = -d.Y(), d.X()  # left normal in (u, v)
            # scale so that the step is `inset` mm on the surface (metric ~ diag(su, sv))
            norm3 = float(np.hypot(nx * su, ny * sv))
            if norm3 < 1e-15:
                continue
            k = inset / norm3
            out.append((a + sign * k * nx, b + sign * k * ny))
            out.append((a - sign * k * nx, b - sign * k * ny))  # the other side: a seam's
    return np.array(out, dtype=float).reshape(-1, 2)


def _vec2d():
    from OCP.gp import gp_Vec2d

    return gp_Vec2d()


def _vec3():
    from OCP.gp import gp_Vec

    return gp_Vec()


def face_distances(face, points: np.ndarray) -> np.ndarray:
    """(N,) exact distance (mm) from each point to the trimmed face (`BRepExtrema`)."""
    out = np.empty(len(points))
    for i, p in enumerate(np.asarray(points, dtype=float)):
        v = BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, p))).Vertex()
        d = BRepExtrema_DistShapeShape(v, face)
        out[i] = d.Value() if d.IsDone() else np.inf
    return out


@dataclass(frozen=True)
class OccMesh:
    """`vertices (V, 3)`, `triangles (T, 3)` indices, `face (T,)` the face index of each."""

    vertices: np.ndarray
    triangles: np.ndarray
    face: np.ndarray


def mesh_shape(shape, deflection: float, angle: float = 0.2) -> OccMesh:
    """OpenCASCADE's own triangles of the shape (`BRepMesh_IncrementalMesh`, linear deflection
    `deflection` mm, angular `angle` rad), face by face in `faces` order."""
    BRepMesh_IncrementalMesh(shape, deflection, False, angle, True)
    verts, tris, owner, base = [], [], [], 0
    for k, f in enumerate(faces(shape)):
        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(f, loc)
        if tri is None:
            continue
        trsf = loc.Transformation()
        v = np.array([tri.Node(i).Transformed(trsf).Coord()
                      for i in range(1, tri.NbNodes() + 1)])
        t = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)]) - 1
        if f.Orientation() == TopAbs_REVERSED:
            t = t[:, ::-1]
        verts.append(v)
        tris.append(t + base)
        owner.append(np.full(len(t), k))
        base += len(v)
    return OccMesh(np.concatenate(verts), np.concatenate(tris).astype(np.int64),
                   np.concatenate(owner))


__all__ = ["CAD_SUFFIXES", "FaceSamples", "OccMesh", "cad_files", "face_distances", "faces",
           "mesh_shape", "read_shape", "sample_face"]
