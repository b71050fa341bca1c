"""Allowable sizes against closed-form truths derived for exact rational NURBS parts.

Bowl (sphere radius rho, concave): a ball of radius rho fits everywhere (r* = rho). A bull-nose of
corner r (r = 0: a flat end-mill, whose bottom rim passes through the CC point and whose limit there
is the closed form of checker/engine/refine/limits.py) touching at polar angle phi from the bottom:
its corner circle lies in the horizontal plane of the fillet centre O, whose section of the offset
sphere (radius rho - r) is a circle through O of radius (rho - r) sin(phi) centred on the bowl axis,
so R* = (rho - r) sin(phi) (the corner circle coincides with it). Groove (cylinder radius rho,
concave): the same argument in the strip |y| <= (rho - r) sin(phi) gives R* = (rho - r) sin(phi),
and r* = rho for a ball.
Tilted floor + wall at x = X: a ball of radius r touching at the origin has its centre at r n
with n_x = 0, it reaches the wall when r = X; a bull-nose (corner r0, axis at x = 0) reaches it
when R + r0 = X. The floor never limits (a convex cutter tangent to a plane)."""

from __future__ import annotations

import numpy as np
import pytest
from engine_parts import bowl, floor_and_wall, groove

from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import sample_part

TOL = 1e-4


def _cc(part, u, v):
    ev = evaluate(part.surfaces[0], u, v)
    return ev.points, ev.normals


@pytest.mark.parametrize("cut", ["CUTTER/10,5", "CUTTER/12,2", "CUTTER/8,1", "CUTTER/10"])
def test_bowl(cut):
    rho = 20.0
    part, g = bowl(rho)
    # the checker surface equals geomdl's exact rational surface
    assert np.allclose(evaluate(part.surfaces[0], [0.3], [0.4]).points[0],
                       g.evaluate_single((0.3, 0.4)), atol=1e-10)
    tp = sample_part(part)
    rng = np.random.default_rng(3)
    u, v = rng.uniform(0, 1, 12), rng.uniform(0.15, 0.75, 12)
    cc, n = _cc(part, u, v)
    c = parse_cutter(cut)
    res = allowable(tp, part, c, cc, n, cc_surface=np.zeros(12, int), cc_uv=np.column_stack([u, v]))
    phi = np.arccos(np.clip(n[:, 2], -1, 1))
    truth = np.full(12, rho) if c.kind == "ball" else (rho - c.r) * np.sin(phi)
    assert np.abs(res.size - truth).max() < TOL
    assert np.allclose(np.linalg.norm(res.limiting_point - [0, 0, rho], axis=1), rho, atol=1e-6)
    expect = np.where(c.size > truth + 1e-3, "too_large_near", "fits")
    assert (res.advice == expect).all()


@pytest.mark.parametrize("cut", ["CUTTER/10,5", "CUTTER/12,2", "CUTTER/10"])
def test_groove(cut):
    rho = 15.0
    part, _ = groove(rho, 80.0)
    tp = sample_part(part)
    rng = np.random.default_rng(5)
    u, v = rng.uniform(0.1, 0.9, 12), rng.uniform(0.3, 0.7, 12)
    cc, n = _cc(part, u, v)
    c = parse_cutter(cut)
    res = allowable(tp, part, c, cc, n, cc_surface=np.zeros(12, int), cc_uv=np.column_stack([u, v]))
    phi = np.arccos(np.clip(n[:, 2], -1, 1))
    truth = np.full(12, rho) if c.kind == "ball" else (rho - c.r) * np.sin(phi)
    assert np.abs(res.size - truth).max() < TOL


@pytest.mark.parametrize("cut", ["CUTTER/20,10", "CUTTER/30,3"])
def test_wall_beside_tilted_floor_is_interference(cut):
    x_wall, alpha = 7.5, np.radians(20)
    part = floor_and_wall(alpha, x_wall)
    tp = sample_part(part)
    cc = np.array([[0.0, 0.0, 0.0], [0.0, 5 * np.cos(alpha), 5 * np.sin(alpha)]])
    n = np.tile([0.0, -np.sin(alpha), np.cos(alpha)], (2, 1))
    c = parse_cutter(cut)
    res = allowable(tp, part, c, cc, n, cc_surface=np.zeros(2, int))
    truth = x_wall if c.kind == "ball" else x_wall - c.r
    assert np.abs(res.size - truth).max() < TOL
    assert (res.limiting_surface == 1).all()
    assert np.allclose(res.limiting_point[:, 0], x_wall)
    assert (res.advice == "too_large_far").all()
    smaller = allowable(tp, part, c.with_size(truth - 0.01), cc, n, cc_surface=np.zeros(2, int))
    assert (smaller.advice == "fits").all()


def test_normal_facing_away_is_inaccessible():
    part, _ = bowl(20.0)
    tp = sample_part(part)
    res = allowable(tp, part, parse_cutter("CUTTER/10,5"), [[0, 0, 0]], [[0, 0, -1.0]])
    assert res.advice[0] == "inaccessible" and res.size[0] == 0.0


def test_any_tool_axis_rotated_bowl():
    """The same bowl and CC points turned by a rotation, with the tool axis turned alike, give
    the same sizes (rows with several distinct axes in one call)."""
    from checker.part import Part, Surface

    rho = 20.0
    part, _ = bowl(rho)
    s = part.surfaces[0]
    tp0 = sample_part(part)
    rng = np.random.default_rng(11)
    u, v = rng.uniform(0, 1, 6), rng.uniform(0.2, 0.7, 6)
    cc, n = _cc(part, u, v)
    c = parse_cutter("CUTTER/12,2")
    ref = allowable(tp0, part, c, cc, n, cc_surface=np.zeros(6, int), cc_uv=np.column_stack([u, v]))
    a = np.radians(35.0)
    R = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    turned = Surface(id=0, name="bowl", kind="nurbs", degree_u=2, degree_v=2, knots_u=s.knots_u,
                     knots_v=s.knots_v, ctrlpts=s.ctrlpts @ R.T, weights=s.weights, flip=s.flip)
    part2 = Part([turned])
    tp2 = sample_part(part2)
    axes = np.vstack([np.tile(R @ [0, 0, 1.0], (6, 1)), np.tile([0, 0, 1.0], (6, 1))])
    uv2 = np.tile(np.column_stack([u, v]), (2, 1))
    res = allowable(tp2, part2, c, np.vstack([cc @ R.T] * 2), np.vstack([n @ R.T] * 2), axes,
                    cc_surface=np.zeros(12, int), cc_uv=uv2)
    assert np.abs(res.size[:6] - ref.size).max() < TOL
    # the limiting set is a whole circle of the sphere; any of its points will do
    assert np.allclose(np.linalg.norm(res.limiting_point[:6] @ R - [0, 0, rho], axis=1), rho,
                       atol=1e-6)
