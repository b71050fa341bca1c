"""Two-way coverage of every STEP/IGES part of ../shared/realdata by the triangles the check
judges it on (`checker.geometry.tessellate.part_triangles` at `check.part_deviation`), measured
by OpenCASCADE alone (tests/occ_faces.py):

- faces -> triangles: points of each face inside its trim by OCC's classifier (a grid about
  1/120 of the part's size apart, and points along every edge 0.02 mm inside the face) lie
  within `part_deviation` of the nearest triangle (exact point-triangle distance, candidates
  from the check's own AABB tree `checker.mesh.MeshIndex`). A missing strip along a trim edge or
  a missing band of a face leaves points far from every triangle.
- triangles -> faces: the vertices, edge midpoints and centroids of the triangles along each
  face's border (a triangle with an edge no other triangle of its face shares), the largest
  triangles and random ones lie within `part_deviation` of the face (OCC's surface projection
  `ShapeAnalysis_Surface`; where the foot is outside the trim, the distance to the trimmed face
  by `BRepExtrema`, there within the deviation plus the face's edge tolerance: OpenCASCADE's
  model puts an edge's curve in space and its curve on the face only that close).

Every STEP/IGES file under ../shared/realdata is listed by glob (a new one is included)."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest
from requires import require_extra

from checker.config import Config
from checker.geometry import load_part
from checker.geometry.tessellate import part_triangles
from checker.mesh import MeshIndex

require_extra("OCP", "cad")
from conftest import REALDATA  # noqa: E402
from occ_faces import (  # noqa: E402
    box,
    cad_files,
    face_distances,
    faces,
    read_shape,
    sample_face,
)

PARTS = cad_files(REALDATA) if REALDATA.is_dir() else []
INSET = 0.02       # mm: edge samples this far inside the face
GRID = 120         # the face grid's spacing: the part's box diagonal / GRID
CAP = 50.0         # mm: distances beyond it are reported as "beyond CAP"
BORDER, LARGEST, RANDOM = 600, 200, 200   # triangles measured on the way back, per part

@nb.njit(cache=True)
def _point_triangle(px, py, pz, tv, t):
    """Squared distance from p to triangle t of tv (T, 3, 3): Ericson's closest point."""
    ax, ay, az = tv[t, 0, 0], tv[t, 0, 1], tv[t, 0, 2]
    bx, by, bz = tv[t, 1, 0], tv[t, 1, 1], tv[t, 1, 2]
    cx, cy, cz = tv[t, 2, 0], tv[t, 2, 1], tv[t, 2, 2]
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        qx, qy, qz = ax, ay, az
    else:
        bpx, bpy, bpz = px - bx, py - by, pz - bz
        d3 = abx * bpx + aby * bpy + abz * bpz
        d4 = acx * bpx + acy * bpy + acz * bpz
        cpx, cpy, cpz = px - cx, py - cy, pz - cz
        d5 = abx * cpx + aby * cpy + abz * cpz
        d6 = acx * cpx + acy * cpy + acz * cpz
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            qx, qy, qz = bx, by, bz
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            s = d1 / (d1 - d3) if d1 > d3 else 0.0  # d1 - d3 = |ab|^2: 0 when a = b
            qx, qy, qz = ax + s * abx, ay + s * aby, az + s * abz
        elif d6 >= 0.0 and d5 <= d6:
            qx, qy, qz = cx, cy, cz
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            s = d2 / (d2 - d6) if d2 > d6 else 0.0
            qx, qy, qz = ax + s * acx, ay + s * acy, az + s * acz
        elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
            s = (d4 - d3) / max((d4 - d3) + (d5 - d6), 1e-300)
            qx, qy, qz = bx + s * (cx - bx), by + s * (cy - by), bz + s * (cz - bz)
        else:
            den = va + vb + vc
            if den <= 0.0:  # degenerate triangle: its vertices
                best = 1e300
                for k in range(3):
                    e = ((px - tv[t, k, 0]) ** 2 + (py - tv[t, k, 1]) ** 2
                         + (pz - tv[t, k, 2]) ** 2)
                    best = min(best, e)
                return best
            v = vb / den
            w = vc / den
            qx = ax + v * abx + w * acx
            qy = ay + v * aby + w * acy
            qz = az + v * abz + w * acz
    return (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2


@nb.njit(cache=True)
def _box2(px, py, pz, lo, hi, n):
    """Squared distance from p to node n's box."""
    d = 0.0
    for a, p in ((0, px), (1, py), (2, pz)):
        if p < lo[n, a]:
            d += (lo[n, a] - p) ** 2
        elif p > hi[n, a]:
            d += (p - hi[n, a]) ** 2
    return d


@nb.njit(cache=True)
def nearest(points, lo, hi, left, right, start, count, tv, tri_id, cap):
    """Exact distance from each point to the nearest triangle of an AABB tree (at most cap),
    and that triangle (-1 when none is nearer than cap): depth-first, nearer child first,
    nodes farther than the best found skipped."""
    n = points.shape[0]
    dist = np.empty(n)
    which = np.full(n, -1, dtype=np.int64)
    stack = np.empty(256, dtype=np.int64)
    for i in range(n):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        best = cap * cap
        bt = -1
        sp = 1
        stack[0] = 0
        while sp > 0:
            sp -= 1
            node = stack[sp]
            if _box2(px, py, pz, lo, hi, node) >= best:
                continue
            if left[node] < 0:
                for j in range(start[node], start[node] + count[node]):
                    d = _point_triangle(px, py, pz, tv, j)
                    if d < best:
                        best = d
                        bt = tri_id[j]
                continue
            a, b = left[node], right[node]
            if _box2(px, py, pz, lo, hi, a) < _box2(px, py, pz, lo, hi, b):
                a, b = b, a
            stack[sp] = a
            stack[sp + 1] = b
            sp += 2
        dist[i] = np.sqrt(best)
        which[i] = bt
    return dist, which


def nearest_distances(index: MeshIndex, points: np.ndarray, cap: float = CAP):
    """(N,) exact distance (mm) from each point to the nearest triangle of `index` (at most
    `cap`: `cap` when none is nearer), and (N,) that triangle's index (-1 when none)."""
    return nearest(np.ascontiguousarray(points, dtype=float), index.node_lo, index.node_hi,
                   index.node_left, index.node_right, index.node_start, index.node_count,
                   index.tri_verts, index.tri_id, cap)


@pytest.fixture(scope="module", params=PARTS, ids=lambda p: p.name)
def cad(request, realdata):
    """(path, the check's triangles, OCC's faces, their samples, part_deviation)."""
    path = request.param
    cfg = Config()
    part = load_part(path, geometry=cfg.geometry)
    tris = part_triangles(part, cfg.check.part_deviation, cfg.geometry)
    shape = read_shape(path)
    occ = faces(shape)
    assert len(occ) == len(part.surfaces), "OCC's faces and pathcheck's surfaces do not match"
    lo, hi = box(shape)
    diag = float(np.linalg.norm(hi - lo))
    samples = [sample_face(f, diag / GRID, INSET) for f in occ]
    return path, tris, occ, samples, cfg.check.part_deviation


@pytest.mark.slow
def test_every_face_is_covered_by_the_triangles(cad):
    path, tris, occ, samples, deviation = cad
    index = MeshIndex.build(tris.vertices, tris.triangles)
    pts = np.concatenate([s.points for s in samples])
    face = np.concatenate([np.full(len(s.points), k) for k, s in enumerate(samples)])
    edge = np.concatenate([s.edge for s in samples])
    assert len(pts) >= 20 * len(occ) and edge.any()
    dist, _ = nearest_distances(index, pts)
    far = dist > deviation
    worst = int(np.argmax(dist))
    faces_far = np.unique(face[far]).tolist()
    assert not far.any(), (
        f"{path.name}: {far.sum()} of {len(pts)} face points ({(far & edge).sum()} of "
        f"{edge.sum()} along edges) lie beyond {deviation} mm of the triangles, up to "
        f"{dist[worst]:.4f} mm (face {face[worst]} at {np.round(pts[worst], 3).tolist()}); "
        f"faces {faces_far}")


def _triangle_points(tris, rng) -> tuple[np.ndarray, np.ndarray]:
    """The points measured on the way back: (points (N, 3), their triangles (N,))."""
    T = tris.triangles
    s = tris.surface
    # a border triangle has an edge no other triangle of its surface shares
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    owner = np.tile(np.arange(len(T)), 3)
    n = np.int64(len(tris.vertices))
    key = (s[owner].astype(np.int64) * n + e[:, 0]) * n + e[:, 1]
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    border = np.unique(owner[cnt[inv] == 1])
    v = tris.vertices[T]
    longest = np.max(np.linalg.norm(v - np.roll(v, 1, axis=1), axis=2), axis=1)
    pick = np.unique(np.concatenate([
        rng.choice(border, min(BORDER, len(border)), replace=False),
        np.argsort(longest)[-LARGEST:],
        rng.choice(len(T), min(RANDOM, len(T)), replace=False)]))
    w = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [.5, .5, 0], [0, .5, .5], [.5, 0, .5],
                  [1 / 3, 1 / 3, 1 / 3]])
    pts = np.einsum("kj,tjc->tkc", w, v[pick]).reshape(-1, 3)
    return pts, np.repeat(pick, len(w))


def surface_distances(face, samples, points: np.ndarray,
                      deviation: float) -> tuple[np.ndarray, np.ndarray]:
    """(N,) exact distance (mm) from points to the trimmed face, and (N,) whether the
    point's foot lies outside the trim: the projection onto its
    surface (`ShapeAnalysis_Surface`, started from the (u, v) of the nearest of the face's
    `samples`, and from scratch where that finds more than `deviation`) where the foot is in
    the trim or on it (the classifier's tolerance: 1e-3 mm on the surface), else the distance
    to the face (`face_distances`, BRepExtrema)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepClass import BRepClass_FaceClassifier
    from OCP.gp import gp_Pnt, gp_Pnt2d, gp_Vec
    from OCP.ShapeAnalysis import ShapeAnalysis_Surface
    from OCP.TopAbs import TopAbs_IN, TopAbs_ON
    from scipy.spatial import cKDTree

    sas = ShapeAnalysis_Surface(BRep_Tool.Surface_s(face))
    guess = (samples.uv[cKDTree(samples.points).query(points)[1]] if len(samples.points)
             else None)
    cls = BRepClass_FaceClassifier()
    adaptor = BRepAdaptor_Surface(face, True)
    out = np.empty(len(points))
    off = np.zeros(len(points), dtype=bool)
    for i, p in enumerate(points):
        q = gp_Pnt(*map(float, p))
        if guess is not None:
            uv = sas.NextValueOfUV(gp_Pnt2d(*map(float, guess[i])), q, 1e-9, -1.0)
        if guess is None or sas.Gap() > deviation:
            uv = sas.ValueOfUV(q, 1e-9)
        out[i] = sas.Gap()
        du, dv = gp_Vec(), gp_Vec()
        adaptor.D1(uv.X(), uv.Y(), gp_Pnt(), du, dv)
        tol = 1e-3 / max(du.Magnitude(), dv.Magnitude(), 1e-12)
        cls.Perform(face, uv, tol)
        off[i] = cls.State() not in (TopAbs_IN, TopAbs_ON)
    if off.any():
        out[off] = face_distances(face, points[off])
    return out, off


def edge_tolerance(face) -> float:
    """The largest tolerance (mm) of the face's edges: how far OpenCASCADE's model lets an
    edge's curve in space lie from its curve on the face (an IGES part 40 m long: 0.2 mm)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    worst, edges = 0.0, TopExp_Explorer(face, TopAbs_EDGE)
    while edges.More():
        worst = max(worst, BRep_Tool.Tolerance_s(TopoDS.Edge(edges.Current())))
        edges.Next()
    return worst


@pytest.mark.slow
def test_every_triangle_lies_on_its_face(cad):
    path, tris, occ, samples, deviation = cad
    pts, tri = _triangle_points(tris, np.random.default_rng(len(tris.triangles)))
    owner = tris.surface[tri]
    dist, allowed = np.empty(len(pts)), np.full(len(pts), deviation)
    for k in np.unique(owner):
        rows = np.flatnonzero(owner == k)
        dist[rows], off = surface_distances(occ[k], samples[k], pts[rows], deviation)
        # beyond the trim, the face's boundary is only known to its edges' tolerance
        allowed[rows[off]] = deviation + edge_tolerance(occ[k])
    worst = int(np.argmax(dist - allowed))
    far = dist > allowed
    assert not far.any(), (
        f"{path.name}: {far.sum()} of {len(pts)} triangle points lie beyond {deviation} mm of "
        f"their face (or their edges' tolerance beyond the trim), up to {dist[worst]:.4f} mm "
        f"(face {owner[worst]} at "
        f"{np.round(pts[worst], 3).tolist()})")


def _brute_distances(points: np.ndarray, tv: np.ndarray) -> np.ndarray:
    """(N,) distance from each point to the nearest triangle of tv (T, 3, 3), every pair: the
    plane where the foot is inside the triangle (barycentric), else the nearest of its edges."""
    a, b, c = tv[:, 0], tv[:, 1], tv[:, 2]
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n, axis=1)[:, None]
    p = points[:, None, :]
    h = np.einsum("ntc,tc->nt", p - a, n)
    foot = p - h[..., None] * n
    inside = np.ones(h.shape, dtype=bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ntc,tc->nt", np.cross(v - u, foot - u), n) >= 0.0
    best = np.where(inside, np.abs(h), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        e = v - u
        s = np.clip(np.einsum("ntc,tc->nt", p - u, e) / np.einsum("tc,tc->t", e, e), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - (u + s[..., None] * e), axis=2))
    return best.min(axis=1)


def test_nearest_distance_is_exact():
    rng = np.random.default_rng(39)
    centres = rng.uniform(-20.0, 20.0, (300, 1, 3))
    tv = centres + rng.normal(0.0, 2.0, (300, 3, 3))
    vertices, triangles = tv.reshape(-1, 3), np.arange(900).reshape(-1, 3)
    points = rng.uniform(-25.0, 25.0, (2000, 3))
    dist, tri = nearest_distances(MeshIndex.build(vertices, triangles), points)
    want = _brute_distances(points, tv)
    np.testing.assert_allclose(dist, np.minimum(want, CAP), rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        [_brute_distances(points[i:i + 1], tv[t:t + 1])[0] for i, t in enumerate(tri[:50])],
        dist[:50], rtol=0, atol=1e-9)
