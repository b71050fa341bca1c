"""Exact tool-vs-mesh depth (checker.mesh): closed forms, a brute force over densely sampled
triangles against `Cutter.signed_distance`, the BVH against testing every triangle, the allowable
size on a mesh, and the chordal deviation of tessellated cylinders."""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest
from mesh_gjk_oracle import gjk_pose_depths

from checker.cutter import Cutter, diameter_from, parse_cutter
from checker.mesh import MeshIndex, allowable_on_mesh, chordal_deviation, pose_depths, tool_pieces
from checker.mesh.tool import UNBOUNDED

Z = np.array([0.0, 0.0, 1.0])


def quad(p0, p1, p2, p3):
    """Two triangles of the quad p0 p1 p2 p3 (counter-clockwise seen from its normal)."""
    v = np.array([p0, p1, p2, p3], dtype=float)
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def floor(z: float, half: float = 100.0):
    return quad([-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z])


def wall_x(x: float, half: float = 100.0):
    """The plane x = const as a big square, normal -x (facing the tool at the origin)."""
    return quad([x, -half, -half], [x, -half, half], [x, half, half], [x, half, -half])


def depth(vt, cutter, tips, axes=Z, reach=10.0, with_holder=True):
    v, t = vt
    idx = MeshIndex.build(v, t)
    return pose_depths(idx, tool_pieces(cutter, with_holder=with_holder),
                       np.atleast_2d(np.asarray(tips, dtype=float)), axes, reach=reach)


def rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


# ---- (a) closed forms ----------------------------------------------------------------------


@pytest.mark.parametrize("z, expected", [(-0.5, -0.5), (0.0, 0.0), (0.3, 0.3), (2.0, 2.0),
                                         (7.0, 5.0), (-20.0, -10.0)])
def test_flat_over_a_floor(z, expected):
    """Flat D10, tip at the origin, floor at height z: depth z up to R = 5 (the disc of radius
    R - t at height t still meets the floor for t <= min(z, R)); below the tip a clearance,
    capped at -reach."""
    res = depth(floor(z), parse_cutter("CUTTER/10"), [[0.0, 0.0, 0.0]])
    assert res.depth[0] == pytest.approx(expected, abs=1e-9)
    assert res.piece[0] == (0 if expected > 0 else -1)
    if expected > -10.0:
        assert res.triangle[0] in (0, 1)
        assert res.point[0, 2] == pytest.approx(z, abs=1e-9)
    else:
        assert res.triangle[0] == -1 and np.isnan(res.point[0]).all()


def test_translated_and_tilted_floor_poses():
    """The same floor seen from many tips and from a tilted axis: depth = height of the floor
    above the tip along the normal for a ball (the sphere of radius r centred r above the tip)."""
    c = parse_cutter("CUTTER/6,3")
    rng = np.random.default_rng(1)
    tips = np.c_[rng.uniform(-50, 50, (50, 2)), rng.uniform(-4, 1, 50)]
    res = depth(floor(0.0), c, tips)
    assert np.allclose(res.depth, np.clip(-tips[:, 2], -10, 3.0), atol=1e-9)
    # tilted by 30 degrees: the ball's lowest point is still the tip-side of the sphere
    a = np.array([math.sin(0.5), 0.0, math.cos(0.5)])
    centre_h = tips[:, 2] + 3.0 * a[2]
    expected = np.clip(3.0 - centre_h, -10, 3.0)
    expected = np.where(3.0 - centre_h > 3.0, 3.0, expected)
    res = depth(floor(0.0), c, tips, axes=a)
    assert np.allclose(res.depth, expected, atol=1e-9)


def test_flat_side_into_a_wall():
    """A vertical wall overlapping the side of a flat D10 by 0.05: depth 0.05, deepest point on
    the wall's line nearest the axis."""
    res = depth(wall_x(4.95), parse_cutter("CUTTER/10"), [[0.0, 0.0, 0.0]])
    assert res.depth[0] == pytest.approx(0.05, abs=1e-9)
    assert res.point[0, 0] == pytest.approx(4.95, abs=1e-12)
    assert abs(res.point[0, 1]) < 1e-4 and res.point[0, 2] >= 0.05 - 1e-9
    res = depth(wall_x(5.2), parse_cutter("CUTTER/10"), [[0.0, 0.0, 0.0]])
    assert res.depth[0] == pytest.approx(-0.2, abs=1e-9)


def test_ball_centre_just_above_a_floor():
    """Ball r = 5 whose centre is 4.9 above the floor: depth 0.1."""
    res = depth(floor(0.0), parse_cutter("CUTTER/10,5"), [[1.0, 2.0, -0.1]])
    assert res.depth[0] == pytest.approx(0.1, abs=1e-9)
    assert np.allclose(res.point[0], [1.0, 2.0, 0.0], atol=1e-9)


def test_a_wall_seen_edge_on_crossing_the_axis():
    """A triangle of a wall parallel to a ball's axis (r = 3), 0.5 mm from it and crossing it
    above the ball's centre, turned about the axis to 60 angles, each at 10 random poses:
    depth 3 - 0.5. Its shadow along the axis is a sliver, whose nearest point rounding used to
    misplace (5 of these 600 poses reported ~0.2)."""
    ball = parse_cutter("CUTTER/6,3")
    t = np.array([-8.0, 9.0, -4.0])  # along the wall, mm
    z = np.array([2.0, -1.0, 7.0])  # it spans z in [0.59, 4.54] where it crosses the axis
    rng = np.random.default_rng(5)
    for phi in np.linspace(0.0, 2.0 * np.pi, 60, endpoint=False):
        n, d = np.array([np.cos(phi), np.sin(phi)]), np.array([-np.sin(phi), np.cos(phi)])
        v = np.column_stack([0.5 * n + t[:, None] * d, z])
        for _ in range(10):
            Q, off = rotation(rng), rng.normal(0.0, 50.0, 3)
            res = depth((v @ Q.T + off, np.array([[0, 1, 2]])), ball, [off], Q[:, 2])
            assert res.depth[0] == pytest.approx(2.5, abs=1e-9), (phi, res.depth[0])


def test_bullnose_on_a_floor_and_a_wall():
    """Bull-nose D10 r2 (R = 3): a floor 0.25 above the tip cuts 0.25 (the torus' flat bottom),
    a floor 2.5 above cuts 2.5 (the core disc eroded by 0.5), a floor 6 above cuts the full
    radius 5; a wall at 4.9 from the axis cuts 0.1 (the cylindrical side above h = r); a wall
    at 4 cuts 1 only where the side is vertical, and the depth there is 1."""
    c = parse_cutter("CUTTER/10,2")
    for z, d in ((0.25, 0.25), (2.5, 2.5), (6.0, 5.0), (-1.0, -1.0)):
        assert depth(floor(z), c, [[0, 0, 0]]).depth[0] == pytest.approx(d, abs=1e-9)
    assert depth(wall_x(4.9), c, [[0, 0, 0]]).depth[0] == pytest.approx(0.1, abs=1e-9)
    assert depth(wall_x(4.0), c, [[0, 0, 0]]).depth[0] == pytest.approx(1.0, abs=1e-9)
    # the torus corner against a floor under a tilted axis: the nearest point of the torus to
    # the plane is on the fillet: depth = r - (height of the fillet circle's lowest point...)
    a = np.array([math.sin(0.3), 0.0, math.cos(0.3)])
    # fillet circle centre C(phi) = tip + f a + R w(phi); lowest over phi: f a_z - R sin(0.3)
    low = 2.0 * a[2] - 3.0 * math.sin(0.3) - 2.0
    res = depth(floor(0.0), c, [[0, 0, -low - 0.4]], axes=a)
    assert res.depth[0] == pytest.approx(0.4, abs=1e-9)


def polygon_tube(radius: float, n: int, z0: float, z1: float):
    """An open tube: the side of the prism over the regular n-gon (vertices at angles 2 pi k/n)."""
    ang = 2 * np.pi * np.arange(n) / n
    ring = np.c_[radius * np.cos(ang), radius * np.sin(ang)]
    v = np.r_[np.c_[ring, np.full(n, z0)], np.c_[ring, np.full(n, z1)]]
    k = np.arange(n)
    k1 = (k + 1) % n
    t = np.r_[np.c_[k, k1, n + k1], np.c_[k, n + k1, n + k]]
    return v, t


def dist_to_polygon(p: np.ndarray, ring: np.ndarray) -> float:
    a, b = ring, np.roll(ring, -1, axis=0)
    ab = b - a
    s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
    return float(np.min(np.linalg.norm(p - (a + s[:, None] * ab), axis=1)))


@pytest.mark.parametrize("x0", [10.0, 14.5, 16.0, 19.0])
def test_ball_inside_a_tessellated_tube(x0):
    """A ball end-mill r = 3 (unbounded body: a capsule column) parallel to the axis of a tube of
    radius 20 tessellated into 96 facets, its axis at distance x0 from the tube's: signed value
    = 3 - (distance in the cross-section from the tool axis to the polygon), exact on the
    facets; the same after a rigid motion of everything."""
    v, t = polygon_tube(20.0, 96, -50.0, 50.0)
    ring = v[:96, :2]
    expected = 3.0 - dist_to_polygon(np.array([[x0, 0.7]]), ring)
    c = parse_cutter("CUTTER/6,3")
    tip = np.array([[x0, 0.7, -10.0]])
    assert depth((v, t), c, tip).depth[0] == pytest.approx(expected, abs=1e-9)
    rng = np.random.default_rng(int(x0 * 10))
    Q, off = rotation(rng), rng.normal(0, 30, 3)
    res = depth((v @ Q.T + off, t), c, tip @ Q.T + off, axes=Q[:, 2])
    assert res.depth[0] == pytest.approx(expected, abs=1e-9)


def uv_sphere(radius: float, nlat: int, nlon: int):
    th = np.linspace(0, np.pi, nlat + 1)[1:-1]
    ph = 2 * np.pi * np.arange(nlon) / nlon
    T_, P_ = np.meshgrid(th, ph, indexing="ij")
    pts = radius * np.c_[(np.sin(T_) * np.cos(P_)).ravel(), (np.sin(T_) * np.sin(P_)).ravel(),
                         np.cos(T_).ravel()]
    v = np.r_[pts, [[0, 0, radius], [0, 0, -radius]]]
    top, bot = len(pts), len(pts) + 1
    tris = []
    for i in range(nlat - 2):
        for j in range(nlon):
            a, b = i * nlon + j, i * nlon + (j + 1) % nlon
            c, d = a + nlon, b + nlon
            tris += [[a, c, d], [a, d, b]]
    for j in range(nlon):
        tris.append([top, j, (j + 1) % nlon])
        last = (nlat - 2) * nlon
        tris.append([bot, last + (j + 1) % nlon, last + j])
    return v, np.array(tris)


def test_ball_inside_a_tessellated_sphere():
    """A ball cutter (flute length 4: a capsule of radius 3 from the centre c to c + 1 along the
    axis, grown core top) inside a sphere of radius 20 tessellated finely: signed = distance
    from the capsule's far end to the sphere, exact up to the tessellation's sagitta."""
    v, t = uv_sphere(20.0, 90, 180)
    sag = 20.0 * (1 - math.cos(math.radians(2.0)))
    c = Cutter("ball", 6.0, 3.0, 0.0, flute_length=4.0)
    for centre, a in (([0, 0, 0], Z), ([0, 0, 14], Z), ([5, 0, 0], np.array([1.0, 0, 0])),
                      ([0, 0, 18], Z), ([0, 12, 0], np.array([0.0, 0.6, 0.8]))):
        centre = np.asarray(centre, dtype=float)
        tip = centre - 3.0 * a
        # the capsule's far end centre + (4 - 3) a, plus the radius 3, against the sphere
        expected = np.linalg.norm(centre + 1.0 * a) + 3.0 - 20.0
        res = depth((v, t), c, [tip], axes=a, reach=30.0)
        assert expected - 1e-9 <= res.depth[0] <= expected + sag, (centre, a, res.depth[0])


# ---- (b) brute force over sampled triangles ------------------------------------------------


def bary_grid(n: int) -> np.ndarray:
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    u, v = i[keep] / n, j[keep] / n
    return np.c_[1 - u - v, u, v]


def piece_sd(prof: np.ndarray, rho: float, pts: np.ndarray) -> np.ndarray:
    """Independent signed distance (numpy) from tool-frame points to core (+) ball(rho), the core
    the solid of revolution of the convex polygon `prof` (m, 2) (r, h): outside, the distance to
    the polygon's edges in the meridian plane; inside, minus the distance to the edges that are
    not on the axis."""
    q = np.c_[np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2]]
    m = len(prof)
    d_all = np.full(len(q), np.inf)
    d_side = np.full(len(q), np.inf)
    inside = np.ones(len(q), bool) if m >= 3 else np.zeros(len(q), bool)
    for k in range(m):
        a, b = prof[k], prof[(k + 1) % m]
        ab = b - a
        L2 = ab @ ab
        s = np.clip((q - a) @ ab / L2, 0, 1) if L2 > 0 else np.zeros(len(q))
        d = np.linalg.norm(q - (a + s[:, None] * ab), axis=1)
        d_all = np.minimum(d_all, d)
        if not (a[0] == 0 and b[0] == 0) and m >= 3:
            d_side = np.minimum(d_side, d)
            nrm = np.array([ab[1], -ab[0]])
            inside &= (q - a) @ nrm <= 0
    return np.where(inside, -d_side, d_all) - rho


CUTTERS = {
    "flat": parse_cutter("CUTTER/10"),
    "ball": parse_cutter("CUTTER/6,3"),
    "bullnose": parse_cutter("CUTTER/10,2"),
    "tapered_bull": Cutter("apt", diameter_from(3.0, 1.0, 0.0, math.radians(8.0)), 1.0, 3.0,
                           0.0, math.radians(8.0)),
    "drill": Cutter("apt", diameter_from(4.0, 0.0, math.radians(25.0), math.radians(5.0)), 0.0,
                    4.0, math.radians(25.0), math.radians(5.0)),
    "tapered_ball": parse_cutter("CUTTER/9.1633,5,0,5,0,5,60"),
}
CUTTERS["tapered_ball"] = Cutter("tapered_ball", CUTTERS["tapered_ball"].d, 5.0, 0.0, 0.0,
                                 CUTTERS["tapered_ball"].theta)
HOLDERS = {
    "flat+shank+holder": Cutter("flat", 10.0, 0.0, 5.0, flute_length=12.0, shank_diameter=8.0,
                                stickout=20.0, holder_diameter=24.0, holder_length=15.0),
    "bull+shank+holder": Cutter("bullnose", 8.0, 1.5, 2.5, flute_length=6.0, shank_diameter=6.0,
                                stickout=9.0, holder_diameter=16.0, holder_length=10.0),
}


def random_triangles(rng, n: int, zlo: float, zhi: float, xy: float) -> np.ndarray:
    """(n, 3, 3) tool-frame triangles: a third random, a third horizontal, a third vertical."""
    c = np.c_[rng.uniform(-xy, xy, (n, 2)), rng.uniform(zlo, zhi, n)]
    size = rng.uniform(1.0, 12.0, n)
    e = rng.normal(size=(n, 3, 3))
    kind = np.arange(n) % 3
    e[kind == 1, :, 2] = 0.0
    # vertical: two edge directions span a vertical plane
    vert = kind == 2
    hdir = rng.normal(size=(vert.sum(), 3))
    hdir[:, 2] = 0.0
    w = rng.uniform(-1, 1, (vert.sum(), 3, 1))
    s = rng.uniform(-1, 1, (vert.sum(), 3, 1))
    e[vert] = w * hdir[:, None, :] + s * np.array([0.0, 0.0, 1.0])
    e /= np.maximum(np.abs(e).max(axis=(1, 2)), 1e-9)[:, None, None]
    return c[:, None, :] + size[:, None, None] * e


def piece_functions(cutter: Cutter, with_pieces: bool) -> list:
    """-signed distance of each piece, tool-frame points -> values: the body's by
    `Cutter.signed_distance` (bodies unbounded upwards), else `piece_sd` per piece."""
    if not with_pieces:
        return [lambda pts: -cutter.signed_distance(pts)]
    pc = tool_pieces(cutter, with_holder=True)
    return [lambda pts, q=q: -piece_sd(pc.prof[q, : pc.nprof[q]], pc.rho[q], pts)
            for q in range(len(pc))]


def brute(cutter: Cutter, tri: np.ndarray, grid: np.ndarray, with_pieces: bool) -> float:
    """Max over the grid's samples of the tool's -signed distance."""
    pts = grid @ tri
    return float(max(np.max(f(pts)) for f in piece_functions(cutter, with_pieces)))


@pytest.mark.parametrize("name", list(CUTTERS) + list(HOLDERS))
def test_brute_force_random_triangles(name):
    """Per random triangle and pose: exact >= sampled max of -signed_distance - 1e-9, and within
    the sampling resolution (the grid step times the longest edge; -signed_distance is
    1-Lipschitz); the reported point lies on the triangle and -signed_distance there is the
    reported value within 1e-6. Poses: the tool frame mapped by a random rigid motion."""
    cutter = CUTTERS.get(name) or HOLDERS[name]
    with_pieces = name in HOLDERS
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    n, ngrid = 80, 48
    grid = bary_grid(ngrid)
    zhi = 40.0 if with_pieces else 14.0
    xy = 14.0 if with_pieces else 8.0
    tris = random_triangles(rng, n, -3.0, zhi, xy)
    pc = tool_pieces(cutter, with_holder=True)
    worst_over = worst_under = 0.0
    inside = pos = 0
    for k in range(n):
        tri = tris[k]
        Q = rotation(rng) if k % 2 else np.eye(3)
        off = rng.normal(0, 50, 3)
        res = pose_depths(MeshIndex.build(tri @ Q.T + off, np.array([[0, 1, 2]])), pc,
                          off[None], Q[:, 2], reach=100.0)
        ref = brute(cutter, tri, grid, with_pieces)
        edge = max(np.linalg.norm(tri[i] - tri[(i + 1) % 3]) for i in range(3))
        assert res.depth[0] >= ref - 1e-9, (k, res.depth[0], ref)
        assert res.depth[0] <= ref + edge / ngrid + 1e-9, (k, res.depth[0], ref, edge / ngrid)
        worst_under = max(worst_under, ref - res.depth[0])
        worst_over = max(worst_over, res.depth[0] - ref)
        inside += res.depth[0] >= max(cutter.r, 0.1) - 1e-9   # the core reached
        pos += res.depth[0] > 0
        # the reported point is on the triangle and has the reported value (so the depth is
        # not overstated; the samples show it is not understated): the deepest piece's when
        # cutting, the nearest piece's when clear
        p_tool = (res.point[0] - off) @ Q
        bary = np.linalg.lstsq(np.c_[tri[1] - tri[0], tri[2] - tri[0]], p_tool - tri[0],
                               rcond=None)[0]
        assert np.allclose(tri[0] + (tri[1:] - tri[0]).T @ bary, p_tool, atol=1e-9)
        assert bary.min() >= -1e-9 and bary.sum() <= 1 + 1e-9
        vals = [float(f(p_tool[None])[0]) for f in piece_functions(cutter, with_pieces)]
        assert max(vals) == pytest.approx(res.depth[0], abs=1e-6), (k, vals, res.depth[0])
        if res.depth[0] > 0:
            assert vals[res.piece[0]] == pytest.approx(res.depth[0], abs=1e-6)
        else:
            assert res.piece[0] == -1
    assert inside >= 3, "some random triangles should reach the core (cut deeper than r)"
    assert pos >= 10 and n - pos >= 8, "penetrations and clearances both"


# ---- (c) the BVH against every triangle -------------------------------------------------------


def soup(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    c = rng.uniform(-50, 50, (n, 3))
    tri = c[:, None, :] + rng.normal(0, 3.0, (n, 3, 3))
    return tri.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3)


@pytest.mark.parametrize("axis", [Z, np.array([math.sin(0.6), 0.0, math.cos(0.6)])])
@pytest.mark.parametrize("name", ["flat+shank+holder", "bullnose", "tapered_bull"])
def test_bvh_equals_every_triangle(axis, name):
    """The tree's answer equals the maximum over single-triangle meshes of the same pose (the
    triangles copied far apart along y, perpendicular to the axis, each with its own copy of the
    pose, in one call)."""
    cutter = CUTTERS.get(name) or HOLDERS[name]
    rng = np.random.default_rng(7)
    v, t = soup(rng, 200)
    npose = 40
    tips = np.c_[rng.uniform(-35, 35, (npose, 2)), rng.uniform(-40, 50, npose)]
    pc = tool_pieces(cutter, with_holder=True)
    reach = 3.0
    res = pose_depths(MeshIndex.build(v, t), pc, tips, axis, reach=reach)
    T = len(t)
    gap = 1000.0
    shift = np.zeros((T, 3))
    shift[:, 1] = gap * np.arange(T)
    v_far = (v.reshape(T, 3, 3) + shift[:, None, :]).reshape(-1, 3)
    far = MeshIndex.build(v_far, t)
    tips_far = (tips[:, None, :] + shift[None, :, :]).reshape(-1, 3)
    each = pose_depths(far, pc, tips_far, axis, reach=reach)
    per = each.depth.reshape(npose, T)
    assert np.allclose(res.depth, per.max(axis=1), atol=1e-9, rtol=0)
    for i in range(npose):
        if res.triangle[i] >= 0:
            assert per[i, res.triangle[i]] == pytest.approx(res.depth[i], abs=1e-9)
        else:
            assert res.depth[i] == -reach
    assert (res.depth > 0).sum() >= 5 and (res.depth < 0).sum() >= 5


@pytest.mark.parametrize("name", ["ball", "bull+shank+holder"])
def test_a_run_of_poses_equals_each_pose_alone(name):
    """A pose's depth does not depend on the other poses of the call (a branch and bound that
    carried anything from pose to pose would show here): along a path that crosses the
    triangles (small steps, and jumps), the depths equal those of each pose alone, and the
    triangle reported has that depth by itself."""
    cutter = CUTTERS.get(name) or HOLDERS[name]
    rng = np.random.default_rng(11)
    v, t = soup(rng, 400)
    idx = MeshIndex.build(v, t)
    pc = tool_pieces(cutter, with_holder=True)
    s = np.linspace(0.0, 1.0, 300)[:, None]
    tips = np.r_[(1 - s) * [-45.0, -30.0, -20.0] + s * [45.0, 35.0, 30.0],
                 rng.uniform(-45, 45, (30, 3))]
    axis = np.array([math.sin(0.4), 0.2, math.cos(0.4)])
    run = pose_depths(idx, pc, tips, axis, reach=2.0)
    alone = [pose_depths(idx, pc, tips[i:i + 1], axis, reach=2.0) for i in range(len(tips))]
    assert np.allclose(run.depth, [a.depth[0] for a in alone], atol=1e-9, rtol=0)
    hit = np.flatnonzero(run.triangle >= 0)
    for i in hit[::7]:
        k = run.triangle[i]
        single = pose_depths(MeshIndex.build(v[t[k]], np.arange(3)[None, :]), pc, tips[i:i + 1],
                             axis, reach=2.0)
        assert single.depth[0] == pytest.approx(run.depth[i], abs=1e-9)
    assert (run.depth > 0).sum() >= 20 and hit.size >= 60


@pytest.mark.parametrize("name", ["flat", "ball", "bullnose", "tapered_bull", "drill",
                                  "bull+shank+holder"])
def test_gjk_oracle_agrees_with_the_slice_method(name):
    """The product's branch and bound over the 1-D slice minimisation and the GJK oracle
    (tests/mesh_gjk_oracle.py: GJK with bisection on the erosion depth, with the product's
    bounds and with every triangle near the tool) agree within 1e-5 mm; GJK never reports less
    (it keeps the upper end of its bracket where it cannot certify a separation); both name the
    same deepest piece."""
    cutter = CUTTERS.get(name) or HOLDERS[name]
    rng = np.random.default_rng(11)
    v, t = soup(rng, 200)
    idx = MeshIndex.build(v, t)
    tips = np.c_[rng.uniform(-35, 35, (150, 2)), rng.uniform(-40, 50, 150)]
    pc = tool_pieces(cutter, with_holder=True)
    for axis in (Z, np.array([0.3, -0.4, 0.866])):
        a = pose_depths(idx, pc, tips, axis, reach=3.0)
        cut = a.depth > 1e-5
        assert cut.sum() >= 10 and (a.depth < -1e-5).sum() >= 10
        for prune in (True, False):
            b = gjk_pose_depths(idx, pc, tips, axis, reach=3.0, prune=prune)
            assert np.all(b.depth >= a.depth - 1e-9)
            assert np.all(b.depth <= a.depth + 1e-5), np.max(b.depth - a.depth)
            assert np.array_equal(a.piece[cut], b.piece[cut])


def test_far_pose_and_input_checks():
    v, t = floor(0.0)
    idx = MeshIndex.build(v, t)
    pc = tool_pieces(parse_cutter("CUTTER/10"), with_holder=False)
    res = pose_depths(idx, pc, [[0, 0, 1e4], [500, 0, -50]], Z, reach=2.0)
    assert np.all(res.depth == -2.0) and np.all(res.triangle == -1) and np.all(res.piece == -1)
    with pytest.raises(ValueError):
        pose_depths(idx, pc, [[0, 0, 0]], Z, reach=-1.0)
    with pytest.raises(ValueError):
        MeshIndex.build(v, np.array([[0, 1, 7]]))
    assert len(pose_depths(idx, pc, np.zeros((0, 3)), Z, reach=1.0).depth) == 0


def test_tool_pieces():
    c = HOLDERS["bull+shank+holder"]
    pc = tool_pieces(c, with_holder=True)
    assert list(pc.kind) == [0, 1, 2]
    body = pc.prof[0, : pc.nprof[0]]
    assert np.allclose(body, [[0, 1.5], [2.5, 1.5], [2.5, 6.0], [0, 6.0]])
    assert np.allclose(pc.prof[1, :4], [[0, 6], [3, 6], [3, 9], [0, 9]])
    assert np.allclose(pc.prof[2, :4], [[0, 9], [8, 9], [8, 19], [0, 19]])
    assert list(tool_pieces(c, with_holder=False).kind) == [0, 1]
    ball = tool_pieces(parse_cutter("CUTTER/6,3"), with_holder=True)
    assert list(ball.kind) == [0] and ball.nprof[0] == 2 and ball.rho[0] == 3.0
    assert np.allclose(ball.prof[0, :2], [[0, 3], [0, UNBOUNDED]])


# ---- allowable size ---------------------------------------------------------------------------


def test_tip_from_contact_with_rowwise_sizes():
    """`Cutter.tip_from_contact(..., sizes=)` (the allowable search's tips) row by row equals
    the tip of `with_size(s)`."""
    rng = np.random.default_rng(3)
    n = 40
    cc = rng.normal(size=(n, 3))
    nrm = rng.normal(size=(n, 3))
    nrm[:, 2] = np.abs(nrm[:, 2]) + 0.2
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    nrm[:5] = Z
    axes = np.tile(Z, (n, 1))
    s = rng.uniform(0.5, 5, n)
    for c in list(CUTTERS.values()):
        got = c.tip_from_contact(cc, nrm, axes, sizes=s)
        want = np.array([c.with_size(s[i]).tip_from_contact(cc[i:i + 1], nrm[i:i + 1], Z)[0]
                         for i in range(n)])
        assert np.allclose(got, want, atol=1e-12)


def test_allowable_in_a_corner():
    """Floor z = 0 and a wall x = 10; contact at the origin, normal +z: the largest ball is r =
    10, the largest flat R = 10, the largest bull-nose (r = 2) R = 8; a contact at x = -30 is
    safe up to s_max."""
    vf, tf = floor(0.0, 60.0)
    vw, tw = wall_x(10.0, 60.0)
    v = np.r_[vf, vw]
    t = np.r_[tf, tw + 4]
    idx = MeshIndex.build(v, t)
    cc = np.array([[0.0, 0.0, 0.0], [-30.0, 0.0, 0.0]])
    nrm = np.tile(Z, (2, 1))
    for text, want in (("CUTTER/10,5", 10.0), ("CUTTER/10", 10.0), ("CUTTER/10,2", 8.0)):
        s = allowable_on_mesh(idx, parse_cutter(text), cc, nrm, Z, tol=1e-6, s_max=20.0)
        assert s[0] == pytest.approx(want, abs=2e-6) and s[0] <= want + 1e-6
        assert s[1] == np.inf
    # a ball whose axis leans away from the wall: still the ball itself limits it, r = 10
    away = np.array([-np.sin(0.4), 0.0, np.cos(0.4)])
    s = allowable_on_mesh(idx, parse_cutter("CUTTER/10,5"), cc, nrm, away, tol=1e-6, s_max=20.0)
    assert s[0] == pytest.approx(10.0, abs=2e-6)


def test_read_only_inputs():
    """Read-only and broadcast inputs are taken (copied, not compiled for once more)."""
    v, t = floor(0.3)
    idx = MeshIndex.build(v, t)
    pc = tool_pieces(parse_cutter("CUTTER/10"), with_holder=False)
    tips = np.zeros((4, 3))
    tips.flags.writeable = False
    res = pose_depths(idx, pc, tips, np.broadcast_to(Z, (4, 3)), reach=1.0)
    assert np.allclose(res.depth, 0.3)


# ---- (d) chordal deviation ----------------------------------------------------------------------


@pytest.mark.parametrize("n", [24, 48, 200])
def test_chordal_deviation_of_a_tessellated_cylinder(n):
    """A closed cylinder of radius 7 tessellated into n facets (turns of 360/n < 20 degrees): the
    sagitta rho (1 - cos(pi/n)) within 5 % (the caps' edges turn by 90 degrees and the quads'
    diagonals not at all: both left out)."""
    v, t = polygon_tube(7.0, n, 0.0, 30.0)
    v = np.r_[v, [[0, 0, 0], [0, 0, 30]]]
    k = np.arange(n)
    t = np.r_[t, np.c_[np.full(n, 2 * n), (k + 1) % n, k],
              np.c_[np.full(n, 2 * n + 1), n + k, n + (k + 1) % n]]
    expected = 7.0 * (1 - math.cos(math.pi / n))
    assert chordal_deviation(v, t) == pytest.approx(expected, rel=0.05)


def test_chordal_deviation_of_a_cube_is_zero():
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float) * 5
    faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    t = np.array([[f[0], f[1], f[2]] for f in faces] + [[f[0], f[2], f[3]] for f in faces])
    assert chordal_deviation(v, t) == 0.0
