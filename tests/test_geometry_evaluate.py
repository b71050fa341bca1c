"""Batch NURBS evaluation against geomdl and against the closed forms of a sphere and a cylinder."""

from __future__ import annotations

import numpy as np
import pytest
from geomdl import NURBS

from checker.geometry.evaluate import (
    evaluate,
    evaluate_mixed,
    points_mixed,
    principal_curvatures,
)
from checker.geometry.inverse import invert_points
from checker.geometry.primitives import flat_patch, nurbs_cylinder, nurbs_sphere
from checker.part import Part, Surface


def _random_geomdl(rng, p=3, q=2, nu=7, nv=6):
    s = NURBS.Surface()
    s.degree_u, s.degree_v = p, q
    s.ctrlpts_size_u, s.ctrlpts_size_v = nu, nv
    s.ctrlpts = rng.normal(scale=10.0, size=(nu * nv, 3)).tolist()
    s.weights = rng.uniform(0.4, 2.5, nu * nv).tolist()
    s.knotvector_u = [0.0] * (p + 1) + [0.2, 0.2, 0.55][: nu - p - 1] + [1.0] * (p + 1)
    s.knotvector_v = [0.0] * (q + 1) + [0.1, 0.5, 0.8][: nv - q - 1] + [1.0] * (q + 1)
    return s


def _ours(s) -> Surface:
    nu, nv = s.ctrlpts_size_u, s.ctrlpts_size_v
    return Surface(
        id=0, name="g", kind="nurbs", degree_u=s.degree_u, degree_v=s.degree_v,
        knots_u=s.knotvector_u, knots_v=s.knotvector_v,
        ctrlpts=np.array(s.ctrlpts).reshape(nu, nv, 3),
        weights=np.array(s.weights).reshape(nu, nv),
    )  # fmt: skip


def test_matches_geomdl_to_1e10_with_second_derivatives():
    rng = np.random.default_rng(7)
    g = _random_geomdl(rng)
    ours = _ours(g)
    # random points plus knots and the domain corners (span edges are the tricky part)
    u = np.r_[rng.uniform(0, 1, 40), 0.0, 0.2, 0.55, 1.0, 1.0]
    v = np.r_[rng.uniform(0, 1, 40), 0.0, 0.1, 0.5, 0.8, 1.0]
    ev = evaluate(ours, u, v, order=2)
    got = np.stack([ev.points, ev.du, ev.dv, ev.duu, ev.duv, ev.dvv], axis=1)
    want = []
    for a, b in zip(u, v, strict=True):
        d = g.derivatives(a, b, order=2)
        want.append([d[0][0], d[1][0], d[0][1], d[2][0], d[1][1], d[0][2]])
    scale = np.maximum(1.0, np.abs(np.array(want)))
    assert np.max(np.abs(got - np.array(want)) / scale) < 1e-10


def test_sphere_points_normals_and_curvatures_are_exact():
    R, c = 12.5, np.array([3.0, -2.0, 40.0])
    s = nurbs_sphere(R, c)
    rng = np.random.default_rng(1)
    u, v = rng.uniform(0, 1, 500), rng.uniform(0.01, 0.99, 500)
    ev = evaluate(s, u, v, order=2)
    radial = ev.points - c
    assert np.allclose(np.linalg.norm(radial, axis=1), R, atol=1e-12, rtol=0)
    assert np.allclose(ev.normals, radial / R, atol=1e-12)
    k = principal_curvatures(s, u, v)
    assert np.allclose(k.k1, 1 / R, rtol=1e-9) and np.allclose(k.k2, 1 / R, rtol=1e-9)
    s.flip = True  # a spherical pocket: concave as seen by the tool
    k = principal_curvatures(s, u, v)
    assert np.allclose(k.k1, -1 / R, rtol=1e-9) and np.allclose(k.k2, -1 / R, rtol=1e-9)


def test_sphere_pole_gets_the_limit_normal():
    s = nurbs_sphere(5.0)
    ev = evaluate(s, [0.3, 0.7], [0.0, 1.0])
    assert np.allclose(ev.normals, [[0, 0, -1], [0, 0, 1]], atol=1e-6)


def test_cylinder_curvatures_and_directions():
    R = 8.0
    shaft = nurbs_cylinder(R, -5.0, 20.0)
    u = np.linspace(0.0, 1.0, 17)
    v = np.linspace(0.0, 1.0, 17)
    k = principal_curvatures(shaft, u, v)
    assert np.allclose(k.k1, 1 / R, rtol=1e-9) and np.allclose(k.k2, 0.0, atol=1e-12)
    # the zero-curvature direction is the axis
    assert np.allclose(np.abs(k.d2[:, 2]), 1.0, atol=1e-9)
    bore = nurbs_cylinder(R, -5.0, 20.0, inside=True)
    ev = evaluate(bore, u, v)
    assert np.allclose(ev.normals[:, :2], -ev.points[:, :2] / R, atol=1e-12)
    assert np.allclose(principal_curvatures(bore, u, v).k2, -1 / R, rtol=1e-9)


def test_evaluate_mixed_equals_per_surface_evaluation():
    part = Part(surfaces=[nurbs_sphere(4.0, surface_id=0), nurbs_cylinder(3.0, 0, 9, 1),
                          flat_patch([0, 0, 0], [10, 0, 0], [0, 10, 0], 2)])  # fmt: skip
    rng = np.random.default_rng(3)
    ids = rng.integers(0, 3, 1000)
    u, v = rng.uniform(0, 1, 1000), rng.uniform(0, 1, 1000)
    mixed = evaluate_mixed(part, ids, u, v, order=2)
    for sid in range(3):
        sel = ids == sid
        ev = evaluate(part.surfaces[sid], u[sel], v[sel], order=2)
        for f in ("points", "du", "dv", "normals", "duu", "duv", "dvv"):
            assert np.array_equal(getattr(mixed, f)[sel], getattr(ev, f))


def test_points_alone_match_geomdl_and_the_full_evaluation():
    """`points_mixed` (no derivatives) on two rational surfaces, 6,000 points (the parallel
    path): geomdl's points to 1e-10, and the points of `evaluate_mixed` exactly."""
    rng = np.random.default_rng(17)
    gs = [_random_geomdl(rng), _random_geomdl(rng, p=2, q=3, nu=6, nv=7)]
    part = Part(surfaces=[_ours(g) for g in gs])
    part.surfaces[1].id = 1
    ids = rng.integers(0, 2, 6000)
    u, v = rng.uniform(0, 1, 6000), rng.uniform(0, 1, 6000)
    pts = points_mixed(part, ids, u, v)
    assert np.array_equal(pts, evaluate_mixed(part, ids, u, v).points)
    some = rng.choice(6000, 60, replace=False)
    want = np.array([gs[ids[k]].evaluate_single((u[k], v[k])) for k in some])
    assert np.max(np.abs(pts[some] - want) / np.maximum(1.0, np.abs(want))) < 1e-10


def test_out_of_domain_parameters_are_clipped():
    s = flat_patch([0, 0, 0], [10, 0, 0], [0, 5, 0])
    ev = evaluate(s, [-1.0, 2.0], [0.5, 3.0])
    assert np.allclose(ev.points, [[0, 2.5, 0], [10, 5, 0]])


def test_invert_points_recovers_parameters():
    s = _ours(_random_geomdl(np.random.default_rng(11)))
    s.knots_v = 3.0 * s.knots_v - 1.0  # a domain other than [0, 1]
    rng = np.random.default_rng(5)
    u, v = rng.uniform(0.05, 0.95, 200), rng.uniform(-0.9, 1.9, 200)
    pts = evaluate(s, u, v).points
    uu, vv, dist = invert_points(s, pts, u + 0.01, v - 0.01)
    assert dist.max() < 1e-9
    assert np.allclose(uu, u, atol=1e-8) and np.allclose(vv, v, atol=1e-8)


def test_bad_order_rejected():
    with pytest.raises(ValueError, match="order"):
        evaluate(flat_patch([0, 0, 0], [1, 0, 0], [0, 1, 0]), [0.5], [0.5], order=4)
    with pytest.raises(ValueError, match="order"):  # points alone: points_mixed
        evaluate(flat_patch([0, 0, 0], [1, 0, 0], [0, 1, 0]), [0.5], [0.5], order=0)
