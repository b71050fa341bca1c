"""Flat-end positioning by the order of contact (Liu et al. n.d.; checker/five_axis/curvature.py,
contact_order.py; docs/MATH.md §11) on analytic surfaces as exact NURBS: a spherical bowl
(rational), a torus trough (rational) and a paraboloid z = (x^2/a + y^2/b)/2 (polynomial).

Closed forms (kappa: the normal curvature across the feed, bending towards the tool):
- second order (seed eq. 6; Meusnier for the bottom circle of radius R leaning by the lead L
  along the feed: its normal curvature across the feed is sin(L) / R): sin(L) = R kappa, tilt 0
  where the section across the feed is symmetric (kappa_s = 0);
- sphere of radius rho (inside): kappa = 1/rho in every direction, kappa_s = 0: L = asin(R/rho);
  a bull-nose (corner r) meets the parallel sphere of radius rho - r: L = asin(R/(rho - r));
- torus (tube r about a ring of radius Rt, the inside of the tube, v the angle on the tube from
  the outer equator): along the meridian kappa = 1/r, along the parallel kappa = cos(v) /
  (Rt + r cos(v)) (Meusnier); both are constant along their own lines (the torus is a surface
  of revolution and the meridian a circle), so kappa_s = 0 across a feed along either:
  L = asin(R / r) fed along the parallel, asin(R cos(v) / (Rt + r cos(v))) along the meridian;
  the parallel's curvature changes along the meridian: d kappa_par / ds_mer =
  -Rt sin(v) / (r (Rt + r cos(v))^2) (ds_mer = r dv);
- paraboloid at (x0, 0): the plane y = 0 holds the normal, so the section across a feed along
  y is the parabola z = x^2 / (2a) itself: kappa = (1/a) / (1 + x0^2/a^2)^(3/2) and
  d kappa / ds = -3 (x0 / a^3) / (1 + x0^2/a^2)^3 along +x; at the vertex L = asin(R/b) fed
  along x and asin(R/a) along y; off the vertex the third order needs a tilt, (E2) of
  contact_order, checked here by the contact itself: the gap between the effective ellipse and
  the true section grows as x^4 (x^3 without the tilt)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from engine_parts import bowl, facing_up, geomdl_surface, to_surface
from five_axis_parts import tool

from checker.config import default_config
from checker.engine import allowable
from checker.five_axis.contact_order import (
    axis_of,
    ball_width,
    contact,
    contact_order_axes,
    flat_width,
)
from checker.five_axis.curvature import local_surface
from checker.five_axis.lead_tilt import axes_from_angles, local_frames
from checker.five_axis.poses import PoseJudge
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import sample_part
from checker.geometry.tessellate import part_triangles
from checker.part import Part, Surface

RHO, RT, RTUBE = 50.0, 60.0, 25.0   # sphere; torus ring and tube radii (mm)
PA, PB, PL = 40.0, 60.0, 30.0       # paraboloid a, b and half-size (mm)
LEADS = dict(min_lead=math.radians(1.0), max_lead=math.radians(60.0))


def _arc(half: float) -> tuple[np.ndarray, np.ndarray]:
    """A rational quadratic arc of the unit circle from -half to +half (rad) about angle 0 at
    (1, 0): poles (3, 2) (cos, sin) and weights (3,)."""
    return (np.array([[math.cos(half), -math.sin(half)], [1.0 / math.cos(half), 0.0],
                      [math.cos(half), math.sin(half)]]),
            np.array([1.0, math.cos(half), 1.0]))


def torus_trough() -> Part:
    """The inside of a tube of radius RTUBE about a ring of radius RT in the plane y = 0 around
    the line x = 0, z = RT + RTUBE: P(u, v) = O + (RT + RTUBE cos v) (sin u, 0, -cos u) +
    RTUBE sin v (0, 1, 0), u in [-30, 30] degrees along the ring, v in [-60, 60] across the
    tube; the bottom P(0, 0) at the origin, normals towards the tube's axis (concave)."""
    ru, wu = _arc(math.radians(30.0))
    pv, wv = _arc(math.radians(60.0))
    O = np.array([0.0, 0.0, RT + RTUBE])
    P = np.array([[O + (RT + RTUBE * c) * np.array([s_u, 0.0, -c_u])
                   + RTUBE * s * np.array([0.0, 1.0, 0.0]) for c, s in pv] for c_u, s_u in ru])
    g = geomdl_surface(P, np.outer(wu, wv), (2, 2), [0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1])
    return Part([facing_up(to_surface(g, 0, name="torus"))])


def paraboloid() -> Part:
    """z = (x^2/PA + y^2/PB) / 2 on [-PL, PL]^2 as one Bezier patch of degree 2 x 2 (u along
    x, v along y, both from 0 to 1): poles x in (-L, 0, L), z from the Bernstein coefficients
    (L^2, -L^2, L^2) of x^2; normals up (concave)."""
    xs, c = np.array([-PL, 0.0, PL]), np.array([PL * PL, -PL * PL, PL * PL])
    P = np.array([[(xs[i], xs[j], (c[i] / PA + c[j] / PB) / 2) for j in range(3)]
                  for i in range(3)], dtype=float)
    k = np.array([0, 0, 0, 1, 1, 1.0])
    return Part([facing_up(Surface(id=0, name="paraboloid", kind="nurbs", degree_u=2,
                                   degree_v=2, knots_u=k, knots_v=k, ctrlpts=P))])


def _tube_angle(points: np.ndarray) -> np.ndarray:
    """(N,) the angle v on the tube (from the outer equator) of torus points (N, 3)."""
    radial = np.hypot(points[:, 0], points[:, 2] - (RT + RTUBE))
    return np.arctan2(points[:, 1] / RTUBE, (radial - RT) / RTUBE)


def _par_uv(x, y):
    return (np.asarray(x) + PL) / (2 * PL), (np.asarray(y) + PL) / (2 * PL)


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_third_derivatives_against_differences():
    """evaluate(order=3) on the rational bowl: central differences of the exact second
    derivatives (step 1e-4: error ~1e-8 of the scale) agree with the third derivatives."""
    s = bowl(RHO)[0].surfaces[0]
    u, v, h = np.array([0.1, 0.33, 0.6]), np.array([0.3, 0.5, 0.8]), 1e-4
    e = evaluate(s, u, v, order=3)
    pu, mu = evaluate(s, u + h, v, 2), evaluate(s, u - h, v, 2)
    pv, mv = evaluate(s, u, v + h, 2), evaluate(s, u, v - h, 2)
    for got, fd in ((e.duuu, (pu.duu - mu.duu)), (e.duuv, (pu.duv - mu.duv)),
                    (e.duvv, (pv.duv - mv.duv)), (e.dvvv, (pv.dvv - mv.dvv))):
        assert np.allclose(got, fd / (2 * h), rtol=1e-6, atol=1e-6 * np.abs(got).max())
    with pytest.raises(ValueError):
        evaluate(s, u, v, order=4)


def test_local_surface_closed_forms():
    """Principal curvatures and cubic terms against the closed forms of the module docstring."""
    # sphere: umbilic, k = -1/rho (concave), no cubic term in any direction
    part = bowl(RHO)[0]
    ls = local_surface(part, np.zeros(4, int), [0.1, 0.3, 0.55, 0.9], [0.2, 0.4, 0.6, 0.8])
    assert np.allclose([ls.k1, ls.k2], -1.0 / RHO, atol=1e-10)
    assert np.abs(ls.cubic).max() < 1e-9
    # torus at (u, v): meridian 1/r, parallel cos v / (Rt + r cos v), d k_par / ds_mer
    tor = torus_trough()
    uu, vv = np.array([0.5, 0.3, 0.7, 0.45]), np.array([0.5, 0.62, 0.3, 0.85])
    ls = local_surface(tor, np.zeros(4, int), uu, vv)
    ev = evaluate(tor.surfaces[0], uu, vv)
    v = _tube_angle(ev.points)
    mer, par = _unit(ev.dv), _unit(ev.du)
    kpar = np.cos(v) / (RT + RTUBE * np.cos(v))
    assert np.allclose(-ls.normal_curvature(mer), 1.0 / RTUBE, rtol=1e-9)
    assert np.allclose(-ls.normal_curvature(par), kpar, rtol=1e-9)
    assert np.allclose(ls.section_cubic(mer), 0.0, atol=1e-10)
    assert np.allclose(ls.section_cubic(par), 0.0, atol=1e-10)
    # the cubic's X_par^2 X_mer coefficient is d(kappa_par)/ds_mer, mer along increasing v
    cubic = ls.section_cubic  # the homogeneous cubic: any tangent vector, not only unit ones
    mixed = (cubic(par + mer) - cubic(par - mer) - 2.0 * cubic(mer)) / 6.0
    want = -RT * np.sin(v) / (RTUBE * (RT + RTUBE * np.cos(v)) ** 2)
    assert np.abs(v).max() > 0.5
    assert np.allclose(mixed, want, rtol=1e-8, atol=1e-12)
    # paraboloid on y = 0: the parabola z = x^2 / (2a) is the normal section along x
    x0 = np.array([0.0, 10.0, -7.0, 22.0])
    u, w = _par_uv(x0, 0 * x0)
    ls = local_surface(paraboloid(), np.zeros(4, int), u, w)
    tx = _unit(np.cross(np.cross(ls.normal, [1.0, 0, 0]), ls.normal))  # +x in the tangent plane
    q = 1.0 + (x0 / PA) ** 2
    assert np.allclose(-ls.normal_curvature(tx), 1.0 / PA / q ** 1.5, rtol=1e-9)
    assert np.allclose(ls.section_cubic(tx), -3.0 * x0 / PA ** 3 / q ** 3, rtol=1e-8,
                       atol=1e-14)


def _plan(part, cutter, x_uv, feeds, judge=True):
    s = part.surfaces[0]
    ev = evaluate(s, x_uv[:, 0], x_uv[:, 1])
    jd = None
    if judge:
        tri = part_triangles(part, 0.001, default_config().geometry)
        jd = PoseJudge.for_triangles(tri, cutter, 1e-3)
    plan = contact_order_axes(part, cutter, ev.points, ev.normals, feeds,
                              np.zeros(len(x_uv), int), x_uv, judge=jd, **LEADS)
    return ev, plan


def _cutter(text: str):
    return tool(text, 15.0, 10.0, 40.0, 30.0, 30.0)


def test_inclination_matches_the_closed_forms():
    """The planned lead and tilt (from the NURBS, order 3) against the closed forms, before any
    lead is raised by the judge (judge off)."""
    flat, bull = _cutter("CUTTER/10"), _cutter("CUTTER/16,3")   # R = 5; R = 5, r = 3
    part = bowl(RHO)[0]
    uv = np.array([[0.1, 0.2], [0.3, 0.45], [0.62, 0.7], [0.85, 0.3]])
    rng = np.random.default_rng(3)
    feeds = rng.normal(size=(4, 3))
    for cutter, want in ((flat, math.asin(5.0 / RHO)), (bull, math.asin(5.0 / (RHO - 3.0)))):
        _, plan = _plan(part, cutter, uv, feeds, judge=False)
        assert (plan.order == 3).all()
        assert np.allclose(plan.lead, want, atol=1e-9)
        assert np.allclose(plan.tilt, 0.0, atol=1e-9)
    # torus: fed along the parallel (u) and along the meridian (v)
    tor = torus_trough()
    uv = np.array([[0.5, 0.5], [0.3, 0.62], [0.7, 0.3]])
    ev = evaluate(tor.surfaces[0], uv[:, 0], uv[:, 1])
    v = _tube_angle(ev.points)
    for feed, want in ((ev.du, np.full(3, math.asin(5.0 / RTUBE))),
                       (ev.dv, np.arcsin(5.0 * np.cos(v) / (RT + RTUBE * np.cos(v))))):
        _, plan = _plan(tor, flat, uv, feed, judge=False)
        assert np.allclose(plan.lead, want, atol=1e-9) and np.allclose(plan.tilt, 0, atol=1e-9)
    # paraboloid vertex: fed along x the section is y^2/(2b), along y it is x^2/(2a)
    par = paraboloid()
    uv = np.array([_par_uv(0.0, 0.0)] * 2)
    _, plan = _plan(par, flat, uv, np.array([[1.0, 0, 0], [0, 1.0, 0]]), judge=False)
    assert np.allclose(plan.lead, [math.asin(5 / PB), math.asin(5 / PA)], atol=1e-9)
    # off the vertex, fed along y: (E2) with the closed-form kappa, kappa_s
    x0 = np.array([10.0, -7.0, 22.0])
    uv = np.column_stack(_par_uv(x0, 0 * x0))
    ev, plan = _plan(par, flat, uv, np.tile([0, 1.0, 0], (3, 1)), judge=False)
    fr = local_frames(ev.normals, np.tile([0, 1.0, 0], (3, 1)))
    q = 1.0 + (x0 / PA) ** 2
    sx = np.einsum("ij,j->i", fr.s, [1.0, 0, 0])  # s = +-x: the sign of kappa_s across
    want = contact(1 / PA / q ** 1.5, np.sign(sx) * -3 * x0 / PA ** 3 / q ** 3, 5.0, **LEADS)
    assert (plan.order == 3).all() and (np.abs(plan.tilt) > 1e-4).all()
    assert np.allclose(plan.axes, axis_of(fr, want.beta, want.omega), atol=1e-9)


def _section_gap(ev, fr, axis, R, xs):
    """Gap (mm) between the effective ellipse (the bottom circle projected along f) and the
    paraboloid's true section across the feed (the surface points in the plane through the CC
    point spanned by s and n, found by bisection on the height), at offsets `xs` along s."""
    a = axis / np.linalg.norm(axis)
    e1 = _unit(np.cross(a, [0.3, 0.5, 0.1]))
    e2 = np.cross(a, e1)
    ph = np.linspace(0.0, 2 * np.pi, 400001)
    rim = R * (np.cos(ph)[:, None] * e1 + np.sin(ph)[:, None] * e2)
    xe, ye = rim @ fr.s, rim @ fr.n
    low = np.argmin(ye)
    xe, ye = xe - xe[low], ye - ye[low]
    lower = ye < 0.5 * R * max(float(a @ fr.f), 1e-3)
    order = np.argsort(xe[lower])
    gaps = []
    for x in xs:
        g = np.interp(x, xe[lower][order], ye[lower][order])
        lo, hi = -5.0, 5.0  # height t along n: F(t) = z(point) - paraboloid(x, y)
        for _ in range(200):
            t = 0.5 * (lo + hi)
            p = ev + x * fr.s + t * fr.n
            f = p[2] - (p[0] ** 2 / PA + p[1] ** 2 / PB) / 2
            lo, hi = (lo, t) if f * fr.n[2] > 0 else (t, hi)
        gaps.append(g - 0.5 * (lo + hi))
    return np.array(gaps)


def test_third_order_contact_on_the_paraboloid():
    """Off the vertex the derived pose is in third-order contact with the true section: the
    gap's odd part (the cubic term) vanishes to rounding and its even part grows as x^4
    (halving x divides it by about 16); the second-order pose (tilt 0, the same curvature)
    keeps an odd part that grows as x^3 (about 8)."""
    part = paraboloid()
    uv = np.array([_par_uv(18.0, 0.0)])
    feeds = np.array([[0.0, 1.0, 0.0]])
    ev, plan = _plan(part, _cutter("CUTTER/10"), uv, feeds, judge=False)
    fr = local_frames(ev.normals, feeds)
    one = type(fr)(fr.f[0], fr.n[0], fr.s[0])
    xs = np.array([0.8, 0.4, -0.8, -0.4])
    beta = math.sin(plan.lead[0]) * math.cos(plan.tilt[0])
    third = _section_gap(ev.points[0], one, plan.axes[0], 5.0, xs)
    second = _section_gap(ev.points[0], one, axis_of(fr, np.array([beta]), np.zeros(1))[0],
                          5.0, xs)
    odd3, even3 = (third[:2] - third[2:]) / 2, (third[:2] + third[2:]) / 2
    odd2 = (second[:2] - second[2:]) / 2
    assert plan.order[0] == 3 and abs(plan.tilt[0]) > 1e-3
    assert even3[0] / even3[1] == pytest.approx(16.0, rel=0.05)
    assert odd2[0] / odd2[1] == pytest.approx(8.0, rel=0.05)
    assert (np.abs(odd3) < 0.05 * np.abs(odd2)).all()


def _ellipse_gap(x: float, B: float, R: float, rho: float) -> float:
    """Height of the ellipse of semi-axes R, B (a circle for B = R) above the circle of radius
    rho, both touching at x = 0 from above, at x."""
    return B * (1 - math.sqrt(1 - x * x / (R * R))) - (rho - math.sqrt(rho * rho - x * x))


def _exact_width(gap, args, h: float, top: float) -> float:
    """Twice the x in [0, top] where the rising `gap(x, *args)` reaches h (bisection)."""
    lo, hi = 0.0, top
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if gap(mid, *args) <= h else (lo, mid)
    return 2.0 * lo


def test_width_flat_end_against_ball_end(capsys):
    """The paper's claim in a table: inside a sphere of radius rho, a flat end mill (R) at the
    derived lead (the ellipse of semi-axes R, B = R^2/rho, in contact with the section's circle
    up to the quartic) against a ball of the same diameter (radius R), at the same scallop
    height h. Exact widths from the exact gaps (the ellipse B (1 - sqrt(1 - x^2/R^2)) and the
    ball R - sqrt(R^2 - x^2) above the circle rho - sqrt(rho^2 - x^2)); closed forms: flat
    w = 2 (8 h / (kappa (1/R^2 - kappa^2)))^(1/4) (the quartic of §11.3, its leading term:
    kappa_ss of the ellipse is 3 kappa (1/R^2 - kappa^2), the circle's 0), ball
    w = 2 sqrt(2 h / (1/R - kappa)). The flat end's strip is wider, by the factor
    w_flat / w_ball = (8 h / (kappa (1/R^2 - kappa^2)))^(1/4) sqrt((1/R - kappa) / (2 h)),
    growing as h^(-1/4): the planner's widths give the exact factor within 1 %, the closed form
    gives it to its leading order (within 4 % where x <= R/2, up to 12 % near x = R)."""
    rows = []
    for R, rho, h in ((5.0, 50.0, 0.01), (5.0, 50.0, 0.001), (5.0, 50.0, 1e-4),
                      (5.0, 200.0, 0.01), (8.0, 100.0, 0.005), (3.0, 30.0, 0.002)):
        k = 1.0 / rho
        got = contact(np.array([k]), np.array([0.0]), R, **LEADS)
        B = got.beta[0] * R
        assert pytest.approx(R * R / rho) == B
        closed_flat = 2.0 * (8.0 * h / (k * (1 / R ** 2 - k * k))) ** 0.25
        closed_ball = 2.0 * math.sqrt(2.0 * h / (1.0 / R - k))
        flat = float(flat_width(R, got.beta, got.omega, got.order, k, 0.0, h)[0])
        ball = float(ball_width(R, np.array([k]), h)[0])
        assert ball == pytest.approx(closed_ball, rel=1e-12)
        exact_flat = _exact_width(_ellipse_gap, (B, R, rho), h, R)
        exact_ball = _exact_width(_ellipse_gap, (R, R, rho), h, R)
        assert flat == pytest.approx(exact_flat, rel=1e-3)
        assert ball == pytest.approx(exact_ball, rel=0.01)
        assert flat > ball and exact_flat > exact_ball
        assert flat / ball == pytest.approx(exact_flat / exact_ball, rel=0.01)
        factor = closed_flat / closed_ball
        assert factor == pytest.approx(flat / ball, rel=0.04 if closed_flat <= R else 0.12)
        rows.append((R, rho, h, closed_flat, flat, exact_flat, ball, exact_ball, factor,
                     flat / ball))
    with capsys.disabled():
        print("\n  R  rho      h | flat: quartic planner exact | ball: closed exact |"
              " factor: closed planner")
        for r in rows:
            print("{:3.0f} {:4.0f} {:6.4f} | {:13.3f} {:7.3f} {:5.3f} | {:11.3f} {:5.3f} |"
                  " {:14.2f} {:7.2f}".format(*r))
    assert min(r[-1] for r in rows) > 3.0


def test_every_planned_pose_is_gouge_free():
    """On the three surfaces, flat-end and bull-nose: every planned pose is accepted by the
    judge (the real tool with holder on the part's triangles), and the allowable-cutter engine
    at the planned axes finds a size at least the cutter's to 1.5 % (below). The
    derived pose matches the surface across the feed only; behind the contact the flat bottom
    rises as sin(lead) x while a surface more concave along the feed than across rises as
    kappa_f x^2 / 2, so the heel gouges where kappa_f R > sin(lead) (the torus and paraboloid
    fed across their flatter direction): there the lead is raised by 0.5-degree steps, and the
    raise is the least one on that grid (half a step less is rejected); the derived poses the
    judge accepts are kept unraised (the feed along the flatter direction needs none)."""
    rng = np.random.default_rng(7)
    cases = []
    cases.append((bowl(RHO)[0], np.column_stack([rng.uniform(0, 1, 4),
                                                 rng.uniform(0.1, 0.5, 4)])))
    cases.append((torus_trough(), rng.uniform(0.3, 0.7, (4, 2))))
    cases.append((paraboloid(), np.column_stack(_par_uv(rng.uniform(-12, 12, 4),
                                                        rng.uniform(-12, 12, 4)))))
    for part, uv in cases:
        ev = evaluate(part.surfaces[0], uv[:, 0], uv[:, 1])
        feeds = _unit(np.cross(ev.normals, rng.normal(size=(len(uv), 3))))
        for text in ("CUTTER/10", "CUTTER/16,3"):
            cutter = _cutter(text)
            _, plan = _plan(part, cutter, uv, feeds)
            assert plan.found.all(), (part.surfaces[0].name, text, plan.raised)
            tri = part_triangles(part, 0.001, default_config().geometry)
            judge = PoseJudge.for_triangles(tri, cutter, 1e-3)
            assert judge(ev.points, ev.normals, plan.axes).all()
            fr = local_frames(ev.normals, feeds)
            base = plan.lead - plan.raised
            derived_ok = judge(ev.points, ev.normals, axes_from_angles(fr, base, plan.tilt))
            assert (plan.raised[derived_ok] == 0.0).all()
            up = np.flatnonzero(plan.raised > 0)
            less = axes_from_angles(fr, plan.lead[up] - math.radians(0.5), plan.tilt[up], up)
            assert not judge(ev.points[up], ev.normals[up], less).any()
            size = allowable(sample_part(part), part, cutter, ev.points, ev.normals,
                             plan.axes, cc_surface=np.zeros(len(uv), int), cc_uv=uv).size
            # the judge allows 1e-3 mm of depth; the engine's size has no tolerance, and near a
            # tangency a depth of 1e-3 mm is a size short by up to ~1 % (the torus: 4.95)
            assert (size >= 0.985 * cutter.size).all(), (part.surfaces[0].name, text, size)
