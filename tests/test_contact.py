"""CL -> CC on exact rational NURBS (a sphere and a cylinder built with geomdl): the contact point
is recovered to 1e-6 mm for ball and bull-nose cutters at arbitrary tool axes, and a CL pushed
0.1 mm into the part has gap -0.1 mm (for convex parts, translating the cutter by d along the
common normal reduces the distance between the two convex bodies by exactly d)."""

from __future__ import annotations

import numpy as np
import pytest
from geomdl import NURBS, exchange, multi

from checker.apt import read_cl
from checker.apt.read import read_cl_text
from checker.cutter import cutter_from_apt
from checker.cutter_core import Core, project_to_core, signed_distance
from checker.geometry import load_part
from checker.geometry.contact import cl_to_cc, contact_from_toolpath
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import sample_part

W = np.sqrt(0.5)
# full circle of radius 1 in the xy plane: 9 rational quadratic poles, counter-clockwise
CIRCLE = [(1, 0, 1), (1, 1, W), (0, 1, 1), (-1, 1, W), (-1, 0, 1), (-1, -1, W), (0, -1, 1),
          (1, -1, W), (1, 0, 1)]
CIRCLE_KNOTS = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]


def _write(tmp_path, name: str, degree_v: int, knots_v, poles, weights):
    """A rational surface (u around the circle, v along the profile) as a geomdl JSON part."""
    s = NURBS.Surface()
    s.degree_u, s.degree_v = 2, degree_v
    s.ctrlpts_size_u, s.ctrlpts_size_v = len(poles), len(poles[0])
    s.ctrlpts = [list(map(float, p)) for row in poles for p in row]
    s.weights = [float(w) for row in weights for w in row]
    s.knotvector_u, s.knotvector_v = CIRCLE_KNOTS, knots_v
    path = tmp_path / f"{name}.json"
    exchange.export_json(multi.SurfaceContainer(s), str(path))
    return load_part(path)


@pytest.fixture(scope="module")
def sphere(tmp_path_factory):
    """Sphere of radius 20 about (1, 2, 3): circle x half-circle profile from the south pole to
    the north pole; du x dv points outwards."""
    rad, c = 20.0, np.array([1.0, 2.0, 3.0])
    prof = [(0, -1, 1), (1, -1, W), (1, 0, 1), (1, 1, W), (0, 1, 1)]  # (radius, height, weight)
    poles = [[c + rad * np.array([cx * pr, cy * pr, pz]) for pr, pz, _ in prof]
             for cx, cy, _ in CIRCLE]
    weights = [[cw * pw for _, _, pw in prof] for _, _, cw in CIRCLE]
    part = _write(tmp_path_factory.mktemp("sphere"), "sphere", 2, [0, 0, 0, .5, .5, 1, 1, 1],
                  poles, weights)
    return part, c, rad


@pytest.fixture(scope="module")
def cylinder(tmp_path_factory):
    """Cylinder of radius 15 about the z axis from z = -30 to 30, du x dv outwards."""
    rad = 15.0
    poles = [[(rad * cx, rad * cy, z) for z in (-30.0, 30.0)] for cx, cy, _ in CIRCLE]
    weights = [[cw, cw] for _, _, cw in CIRCLE]
    part = _write(tmp_path_factory.mktemp("cyl"), "cylinder", 1, [0, 0, 1, 1], poles, weights)
    return part, rad


def _random_axes(normals: np.ndarray, rng, lo_deg: float, hi_deg: float) -> np.ndarray:
    """Unit axes at a random angle in [lo, hi] degrees from each normal, random azimuth."""
    t = rng.normal(size=normals.shape)
    t -= np.einsum("ij,ij->i", t, normals)[:, None] * normals
    t /= np.linalg.norm(t, axis=1)[:, None]
    ang = np.radians(rng.uniform(lo_deg, hi_deg, len(normals)))[:, None]
    return np.cos(ang) * normals + np.sin(ang) * t


TAPERED = [13.4977, 3.0, 4.0, 3.0, 0.0, 5.0, 50.0]  # tapered bull-nose r 3, 5 deg (thesis ch. 5)
CUTTERS = {"ball D6": [6.0, 3.0], "bull-nose D10 R2": [10.0, 2.0], "tapered bull-nose": TAPERED}


def _check(part, surface_normal_ok, u, v, cutter, rng):
    tp = sample_part(part)
    ev = evaluate(part.surfaces[0], u, v)
    assert surface_normal_ok(ev.points, ev.normals)
    axes = _random_axes(ev.normals, rng, 5.0, 70.0)
    tips = cutter.tip_from_contact(ev.points, ev.normals, axes)
    got = cl_to_cc(part, tp, cutter, tips, axes)
    np.testing.assert_allclose(got.cc, ev.points, atol=1e-6)
    np.testing.assert_allclose(got.normal, ev.normals, atol=1e-6)
    np.testing.assert_allclose(got.gap, 0.0, atol=1e-6)
    pushed = cl_to_cc(part, tp, cutter, tips - 0.1 * ev.normals, axes)
    np.testing.assert_allclose(pushed.gap, -0.1, atol=1e-6)
    np.testing.assert_allclose(pushed.cc, ev.points, atol=1e-6)
    away = cl_to_cc(part, tp, cutter, tips + 0.1 * ev.normals, axes)
    np.testing.assert_allclose(away.gap, 0.1, atol=1e-6)


@pytest.mark.parametrize("name", sorted(CUTTERS))
def test_sphere_contact_recovered(sphere, name):
    part, c, rad = sphere
    rng = np.random.default_rng(7)
    u, v = rng.uniform(0, 1, 200), rng.uniform(0.05, 0.95, 200)

    def outward(p, n):
        return np.allclose(np.linalg.norm(p - c, axis=1), rad) and np.allclose(n, (p - c) / rad)

    _check(part, outward, u, v, cutter_from_apt(CUTTERS[name]), rng)


@pytest.mark.parametrize("name", sorted(CUTTERS))
def test_cylinder_contact_recovered(cylinder, name):
    part, rad = cylinder
    rng = np.random.default_rng(11)
    u, v = rng.uniform(0, 1, 200), rng.uniform(0.2, 0.8, 200)

    def outward(p, n):
        radial = p * [1, 1, 0] / rad
        return np.allclose(np.hypot(p[:, 0], p[:, 1]), rad) and np.allclose(n, radial)

    _check(part, outward, u, v, cutter_from_apt(CUTTERS[name]), rng)


def test_flat_end_mill_touches(sphere):
    """A flat end-mill touches with its sharp corner circle: the squared distance between the
    circle and the sphere grows only to fourth order along the circle (slow Newton), yet the
    contact is found to 1e-4 mm and the gap to 1e-6 mm."""
    part, c, rad = sphere
    rng = np.random.default_rng(13)
    u, v = rng.uniform(0, 1, 100), rng.uniform(0.05, 0.95, 100)
    cutter = cutter_from_apt([8.0])
    ev = evaluate(part.surfaces[0], u, v)
    axes = _random_axes(ev.normals, rng, 5.0, 70.0)
    got = cl_to_cc(part, sample_part(part), cutter,
                   cutter.tip_from_contact(ev.points, ev.normals, axes), axes)
    np.testing.assert_allclose(got.cc, ev.points, atol=1e-4)
    np.testing.assert_allclose(got.gap, 0.0, atol=1e-6)


@pytest.mark.parametrize(("values", "push"), [([8.0], 0.1), ([10.0, 2.0], 3.0)])
def test_deep_penetration(sphere, values, push):
    """Penetrations the squared-distance phase cannot measure (a flat end-mill's sharp corner;
    a bull-nose pushed deeper than its corner radius): the gap is negative, no deeper than the
    push (the signed distance is 1-Lipschitz in the cutter's position), equal to the cutter
    model's own signed distance at the point found (checker.cutter, in the tool frame), and at
    least as deep as the deepest of 250,000 sphere points (brute force, 10 positions)."""
    part, c, rad = sphere
    rng = np.random.default_rng(17)
    u, v = rng.uniform(0, 1, 60), rng.uniform(0.05, 0.95, 60)
    cutter = cutter_from_apt(values)
    ev = evaluate(part.surfaces[0], u, v)
    axes = _random_axes(ev.normals, rng, 5.0, 70.0)
    tips = cutter.tip_from_contact(ev.points, ev.normals, axes) - push * ev.normals
    got = cl_to_cc(part, sample_part(part), cutter, tips, axes)
    assert (got.gap < -1e-3).all() and (got.gap >= -push - 1e-9).all()
    e1 = np.cross(axes, [0.3, 0.5, 0.8])
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(axes, e1)
    rel = got.cc - tips
    tool = np.stack([np.einsum("ij,ij->i", rel, e) for e in (e1, e2, axes)], axis=1)
    np.testing.assert_allclose(got.gap, cutter.signed_distance(tool), atol=1e-9)
    t = np.linspace(0, 1, 500)
    U, V = np.meshgrid(t, np.linspace(0.02, 0.98, 500))
    dense = evaluate(part.surfaces[0], U.ravel(), V.ravel()).points
    core = cutter.core
    for i in range(10):
        tip = np.broadcast_to(tips[i], dense.shape)
        brute = signed_distance(core, dense, tip, np.broadcast_to(axes[i], dense.shape)).min()
        assert got.gap[i] <= brute + 1e-9


def test_contact_data_from_cl_file_is_used(sphere):
    """A CC point given by the CAM starts the search there: the far side of the sphere is never
    reached from the k nearest test points, but is from the given contact."""
    part, c, rad = sphere
    cutter = cutter_from_apt([6.0, 3.0])
    cc = c + rad * np.array([[0.0, 0.6, 0.8]])
    n = (cc - c) / rad
    tips = cutter.tip_from_contact(cc, n, n)
    got = cl_to_cc(part, sample_part(part), cutter, tips, n, contact=cc + 0.3)
    np.testing.assert_allclose(got.cc, cc, atol=1e-6)
    np.testing.assert_allclose(got.gap, 0.0, atol=1e-6)


def test_signed_distance_matches_cutter_model():
    """The core distance equals the cutter model's own signed distance outside the cutter and
    for penetrations shallower than r (checker.cutter, an independent formula)."""
    rng = np.random.default_rng(3)
    for values in ([6.0, 3.0], [10.0, 2.0], [8.0], TAPERED):
        cutter = cutter_from_apt(values)
        pts = rng.uniform([-12, -12, -4], [12, 12, 20], (4000, 3))
        core = cutter.core
        ours = signed_distance(core, pts, np.zeros_like(pts), np.tile([0, 0, 1.0], (len(pts), 1)))
        theirs = cutter.signed_distance(pts)
        keep = theirs > -cutter.r
        np.testing.assert_allclose(ours[keep], theirs[keep], atol=1e-9)


def test_core_hessian_matches_finite_differences():
    """The Hessian of dist^2/2 that drives the Newton steps, against central differences."""
    rng = np.random.default_rng(5)
    core = Core(2.0, 3.0)
    p = rng.uniform([-9, -9, -5], [9, 9, 12], (300, 3))
    tips, axes = np.zeros_like(p), np.tile([0, 0, 1.0], (len(p), 1))
    proj = project_to_core(core, p, tips, axes)
    h = 1e-5
    for k in range(3):
        dp = np.zeros(3)
        dp[k] = h
        gp = p + dp - project_to_core(core, p + dp, tips, axes).q
        gm = p - dp - project_to_core(core, p - dp, tips, axes).q
        col = (gp - gm) / (2 * h)
        ok = proj.dist > 1e-3
        np.testing.assert_allclose(proj.hess[ok, :, k], col[ok], atol=1e-5)


def test_contact_comments_read_in_the_part_frame():
    """`GOTO/... $$ cx,cy,cz` (NX "centerline and contact point") in the frame of the CSYS in
    force: a 90-degree turn about z plus a shift; moves without the comment give nan."""
    tp = read_cl_text("PARTNO/T\nUNITS/MM\nCUTTER/6,3\nCSYS/0,-1,0,10,1,0,0,20,0,0,1,30\n"
                      "FEDRAT/100\nGOTO/1,2,3 $$ 1,2,0\nGOTO/4,5,6\n")
    m = tp.motion_arrays()
    got = contact_from_toolpath(tp, m.line)
    np.testing.assert_allclose(m.tip[0], [8.0, 21.0, 33.0])
    np.testing.assert_allclose(got[0], [8.0, 21.0, 30.0])
    assert np.isnan(got[1]).all()


def test_nx_contact_points_lie_on_the_ball(realdata):
    """The real NX CLSF (inches) in "centerline and contact point" mode: every contact point it
    wrote is r from the ball centre tip + r axis, to the file's 4 decimals of an inch."""
    tp = read_cl(realdata / "mech491-nx-clsf" / "APT_Project2.txt")
    m = tp.motion_arrays()
    cc = contact_from_toolpath(tp, m.line)
    has = np.isfinite(cc).all(axis=1)
    assert has.sum() == 2445
    r = np.array([tp.operations[o].cutter.r for o in m.op[has]])
    assert np.allclose(r, 0.12 * 25.4)
    dist = np.linalg.norm(m.tip[has] + r[:, None] * m.axis[has] - cc[has], axis=1)
    assert np.abs(dist - r).max() < 0.005



def test_depth_gradient_where_a_parameter_degenerates():
    """The deepest-point descent inside the core at a point whose surface tangents are
    degenerate (du = 0 at a pole or a collapsed edge, so J^T J is singular: the bladex root and
    tip sections reach it with a flat D8): the depth and a finite unit gradient (the nearer
    side's normal), never a singular-matrix error."""
    from checker.geometry.contact import _depth_model

    cutter = cutter_from_apt([8.0])
    points = np.array([[0.3, 0.2, -0.4]])
    tips, axes = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    dv = np.array([[[0.0, 1.0], [0.0, 0.0], [0.0, 0.2]]])  # du = 0, dv along +x (and z)
    regular = dv.copy()
    regular[0, :, 0] = [0.0, 1.0, 0.0]  # a du along +y beside it
    f, grad, _ = _depth_model(cutter.core, points, tips, axes, J=dv)
    f_reg, grad_reg, _ = _depth_model(cutter.core, points, tips, axes, J=regular)
    assert np.isfinite(grad).all() and f == pytest.approx(f_reg)
    np.testing.assert_allclose(np.linalg.norm(grad), 1.0, atol=1e-9)

