"""STEP and IGES parts through OpenCASCADE (OCP): every face becomes an exact B-spline surface.

B-spline faces keep their poles, knots and weights (periodic ones are unrolled, same
parameters); analytic and swept faces (plane, cylinder, cone, sphere, torus, revolution,
extrusion, Bezier) are converted exactly to rational B-splines by GeomConvert over the face's
(u, v) bounds. The face's wires become the trim loops in (u, v); for converted faces, whose
B-spline parameters differ from the analytic ones, the loop points are mapped onto the new
parameters by inversion (to 1e-9 mm). Faces reversed in the shell get `flip` so that normals
follow the face orientation (out of the solid). OCC works in mm (its unit conversion applies).

OpenCASCADE runs only in a child process (`checker.sandbox`, `read_occ_arrays`): a damaged
file that crashes or hangs it is one error naming the file; the faces come back as arrays.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from checker.errors import PathcheckError
from checker.extras import require
from checker.geometry.inverse import invert_points
from checker.geometry.packing import pack_surfaces, unpack_surfaces
from checker.geometry.trims import UVTrim
from checker.part import Surface
from checker.sandbox import Limits, run_contained

_KINDS = {
    "GeomAbs_Plane": "plane",
    "GeomAbs_Cylinder": "cylinder",
    "GeomAbs_Cone": "cone",
    "GeomAbs_Sphere": "sphere",
    "GeomAbs_Torus": "torus",
    "GeomAbs_BezierSurface": "bezier",
    "GeomAbs_BSplineSurface": "bspline",
    "GeomAbs_SurfaceOfRevolution": "revolution",
    "GeomAbs_SurfaceOfExtrusion": "extrusion",
    "GeomAbs_OffsetSurface": "offset",
    "GeomAbs_OtherSurface": "other",
}
_CURVE_SAMPLES = 33
_TRIM_DEFLECTION = 1e-3  # mm: chord deviation of the trim polylines from the face's edges
_TRIM_ANGLE = 0.2  # rad: angular deflection of the trim polylines
_MAP_TOL = 1e-9  # mm: trim loop points of converted faces must land this close


def read_occ(path: Path, kind: str, limits: Limits) -> tuple[list[Surface], int]:
    """(surfaces, number of faces) of a STEP (`kind` "step") or IGES ("iges") file, read by
    OpenCASCADE in a contained child process (`checker.sandbox`) under `limits`."""
    require("OCP", "cad", f"reading {kind.upper()} parts")
    arrays = run_contained("checker.geometry.occ_io:read_occ_arrays", [str(path), kind],
                           limits, path, f"the {kind.upper()} reader (OpenCASCADE)")
    surfaces = unpack_surfaces(arrays)
    return surfaces, len(surfaces)


def read_occ_arrays(path: str, kind: str) -> dict[str, np.ndarray]:
    """The child's side of `read_occ`: the file's faces as `pack_surfaces` arrays."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    shape = _read_shape(Path(path), kind)
    surfaces: list[Surface] = []
    ex = TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        face = TopoDS.Face(ex.Current())
        ex.Next()
        try:
            surfaces.append(_face_surface(face, len(surfaces)))
        except Exception as err:  # OCC raises its own Standard_Failure types
            raise PathcheckError(
                f"face {len(surfaces)}: cannot convert to an exact B-spline: {err}",
                path=path,
                code="part",
            ) from err
    return pack_surfaces(surfaces)


read_occ_arrays.preload = ("OCP.STEPControl", "OCP.IGESControl", "OCP.GeomConvert")


def _quiet_occ() -> None:
    """Keep OpenCASCADE's reader chatter off stdout (the library never prints)."""
    from OCP.Message import Message, Message_Gravity

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)


def _read_shape(path: Path, kind: str):
    from OCP.IFSelect import IFSelect_RetDone

    _quiet_occ()

    if kind == "step":
        from OCP.STEPControl import STEPControl_Reader

        reader = STEPControl_Reader()
    else:
        from OCP.IGESControl import IGESControl_Reader

        reader = IGESControl_Reader()
    status = reader.ReadFile(str(path))
    if status != IFSelect_RetDone:
        raise PathcheckError(
            f"not a readable {kind.upper()} file (OpenCASCADE status {status.name})",
            path=path,
            code="part",
        )
    if reader.TransferRoots() == 0:
        raise PathcheckError(
            f"{kind.upper()} file holds no transferable shape", path=path, code="part"
        )
    shape = reader.OneShape()
    if shape.IsNull():
        raise PathcheckError(f"{kind.upper()} file holds no shape", path=path, code="part")
    return shape


def _face_surface(face, index: int) -> Surface:
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.Geom import Geom_BSplineSurface, Geom_RectangularTrimmedSurface
    from OCP.GeomAdaptor import GeomAdaptor_Surface
    from OCP.GeomConvert import GeomConvert
    from OCP.TopAbs import TopAbs_REVERSED

    geom = BRep_Tool.Surface_s(face)
    if isinstance(geom, Geom_RectangularTrimmedSurface):
        geom = geom.BasisSurface()
    kind = _KINDS.get(GeomAdaptor_Surface(geom).GetType().name, "other")
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    converted = not isinstance(geom, Geom_BSplineSurface)
    if converted:
        bs = GeomConvert.SurfaceToBSplineSurface_s(
            Geom_RectangularTrimmedSurface(geom, u0, u1, v0, v1)
        )
    else:
        bs = geom.Copy()
    if bs.IsUPeriodic():
        bs.SetUNotPeriodic()
    if bs.IsVPeriodic():
        bs.SetVNotPeriodic()
    surf = _bspline_data(bs, index, kind, face.Orientation() == TopAbs_REVERSED)
    loops = _face_loops(face)
    if converted and loops:
        loops = _map_loops(geom, surf, loops)
    surf.trim = _trim_or_none(surf, loops)
    return surf


def _bspline_data(bs, index: int, kind: str, flip: bool) -> Surface:
    """Poles, flat knots and weights of a non-periodic Geom_BSplineSurface (element by element:
    OCP's whole-array accessors are not safe to hold)."""
    nu, nv = bs.NbUPoles(), bs.NbVPoles()
    ctrl = np.empty((nu, nv, 3))
    w = np.empty((nu, nv))
    for i in range(nu):
        for j in range(nv):
            p = bs.Pole(i + 1, j + 1)
            ctrl[i, j] = p.X(), p.Y(), p.Z()
            w[i, j] = bs.Weight(i + 1, j + 1)
    ku = np.repeat(
        [bs.UKnot(i) for i in range(1, bs.NbUKnots() + 1)],
        [bs.UMultiplicity(i) for i in range(1, bs.NbUKnots() + 1)],
    )
    kv = np.repeat(
        [bs.VKnot(i) for i in range(1, bs.NbVKnots() + 1)],
        [bs.VMultiplicity(i) for i in range(1, bs.NbVKnots() + 1)],
    )
    rational = bool(np.ptp(w) > 1e-14 * w.max())
    if kind == "bspline" and rational:
        kind = "nurbs"
    return Surface(
        id=index,
        name=f"face_{index}_{kind}",
        kind=kind,
        degree_u=bs.UDegree(),
        degree_v=bs.VDegree(),
        knots_u=ku,
        knots_v=kv,
        ctrlpts=ctrl,
        weights=w if rational else None,
        flip=flip,
    )


def _face_loops(face) -> list[np.ndarray]:
    """One closed (K, 2) (u, v) polyline per wire of the face, edges in wire order."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.BRepTools import BRepTools_WireExplorer
    from OCP.TopAbs import TopAbs_REVERSED, TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    loops = []
    wires = TopExp_Explorer(face, TopAbs_WIRE)
    while wires.More():
        wire = TopoDS.Wire(wires.Current())
        wires.Next()
        pieces = []
        we = BRepTools_WireExplorer(wire, face)
        while we.More():
            edge = we.Current()
            we.Next()
            c2d = BRepAdaptor_Curve2d(edge, face)
            t = _edge_params(edge, c2d)
            if edge.Orientation() == TopAbs_REVERSED:
                t = t[::-1]
            pieces.append(np.array([(q.X(), q.Y()) for q in map(c2d.Value, t)]))
        if pieces:
            loops.append(np.concatenate(pieces))
    return loops


def _edge_params(edge, c2d) -> np.ndarray:
    """Edge parameters whose 3-D chords deviate at most _TRIM_DEFLECTION mm from the edge (the
    pcurve shares the edge's parameter); uniform for degenerated or non-same-parameter edges."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_TangentialDeflection

    t0, t1 = c2d.FirstParameter(), c2d.LastParameter()
    if BRep_Tool.Degenerated_s(edge) or not BRep_Tool.SameParameter_s(edge):
        return np.linspace(t0, t1, _CURVE_SAMPLES)
    curve = BRepAdaptor_Curve(edge)
    defl = GCPnts_TangentialDeflection(curve, t0, t1, _TRIM_ANGLE, _TRIM_DEFLECTION, 2)
    t = np.array([defl.Parameter(i) for i in range(1, defl.NbPoints() + 1)])
    return np.clip(t, min(t0, t1), max(t0, t1))


def _map_loops(geom, surf: Surface, loops: list[np.ndarray]) -> list[np.ndarray]:
    """Loops in the analytic surface's (u, v) -> the converted B-spline's (u, v)."""
    uv = np.concatenate(loops)
    pts = np.array([(p.X(), p.Y(), p.Z()) for p in (geom.Value(a, b) for a, b in uv)])
    u, v, dist = invert_points(surf, pts, uv[:, 0], uv[:, 1])
    if dist.max() > _MAP_TOL:
        raise ValueError(f"trim loop maps onto the converted surface only to {dist.max():.2e} mm")
    cuts = np.cumsum([len(lp) for lp in loops])[:-1]
    return np.split(np.column_stack([u, v]), cuts)


def _trim_or_none(surf: Surface, loops: list[np.ndarray]) -> UVTrim | None:
    """None when the single loop is the whole domain rectangle (an untrimmed face)."""
    if not loops:
        return None
    (u0, u1), (v0, v1) = surf.domain
    if len(loops) == 1:
        x, y = loops[0][:, 0], loops[0][:, 1]
        area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
        if abs(area - (u1 - u0) * (v1 - v0)) <= 1e-9 * (u1 - u0) * (v1 - v0):
            return None
    return UVTrim(loops)
