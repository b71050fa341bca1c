"""Allowable sizes at CC points that ARE test points (CAM CC points often lie on the grid lines of a
flat patch, where the part's samples are), against closed forms, on planes, cylinders and spheres
beside a wall. Every part is moved by an offset that no binary fraction represents, so the
points of a flat face through the CC point lie above or below its tangent plane by rounding
(1e-16 mm), as on a real part.

Closed forms (wall x = X facing -x, CC point Pcc with normal n, tool axis +z):
- ball of radius r: its centre Pcc + r n reaches the wall when Pcc_x + r n_x + r = X;
- R family (corner r, axis through O_h + R e, O = Pcc + r n, e = n_h / |n_h|): its widest
  circle (radius R + r, at O's height) reaches the wall when O_x + R e_x + R + r = X;
- a normal along the axis with no direction e (a horizontal floor): the worst case over e is
  the axis towards the wall, R = (X - Pcc_x - r) / 2 (docs/MATH.md §3.4);
- concave bowl / groove of radius rho: r* = rho (ball), R* = (rho - r) sin(phi)
  (tests/test_engine_closed_form.py).
The part's own convex or flat faces never limit a convex cutter tangent to them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from engine_parts import bowl, facing_up, geomdl_surface, groove, to_surface

from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.geometry.sampling import sample_part
from checker.part import Part

TOL = 1e-4
OFFSET = np.array([0.123, 0.456, 0.789])  # mm: no coordinate stays a binary fraction
CUTTERS = ["CUTTER/6,3", "CUTTER/10,2", "CUTTER/10"]
_S = np.sqrt(0.5)


def _bilinear(corner, eu, ev, sid: int, name: str):
    c, a, b = (np.asarray(t, dtype=float) for t in (corner, eu, ev))
    g = geomdl_surface(np.array([[c, c + b], [c + a, c + a + b]]), np.ones((2, 2)), (1, 1),
                       [0, 0, 1, 1], [0, 0, 1, 1])
    return to_surface(g, sid, name=name)


def _wall(x: float, half: float, z0: float, z1: float):
    """The plane x = `x` facing -x, |y| <= half, z0 <= z <= z1 (surface id 1)."""
    return _bilinear([x, -half, z0], [0, 0, z1 - z0], [0, 2 * half, 0], 1, "wall")


def _moved(surfaces) -> Part:
    """The part of `surfaces` moved by OFFSET (new surfaces: nothing evaluated before is kept)."""
    return Part([replace(s, ctrlpts=s.ctrlpts + OFFSET) for s in surfaces])


def _plane_and_wall(alpha: float, x_wall: float) -> Part:
    """A plane through the origin tilted by `alpha` about x (normal (0, -sin, cos)), x in
    [-40, x_wall], beside the wall x = x_wall (moved by OFFSET)."""
    t = np.array([0.0, np.cos(alpha), np.sin(alpha)])
    floor = _bilinear(np.array([-40.0, 0, 0]) - 30 * t, [40 + x_wall, 0, 0], 60 * t, 0, "plane")
    return _moved([floor, _wall(x_wall, 40.0, -30.0, 60.0)])


def _cylinder_and_wall(rho: float, x_wall: float) -> Part:
    """The upper half of the cylinder of radius rho about the x axis (convex, normals out), x in
    [-40, x_wall], beside the wall x = x_wall (moved by OFFSET)."""
    half = [(-1, 0, 1), (-1, 1, _S), (0, 1, 1), (1, 1, _S), (1, 0, 1)]  # (y, z, w)
    xs = [-40.0, x_wall]
    P = np.array([[(x, y * rho, z * rho) for x in xs] for y, z, _ in half], dtype=float)
    W = np.array([[w, w] for _, _, w in half], dtype=float)
    g = geomdl_surface(P, W, (2, 1), [0, 0, 0, 0.5, 0.5, 1, 1, 1], [0, 0, 1, 1])
    return _moved([facing_up(to_surface(g, 0, name="cylinder")), _wall(x_wall, 60.0, -10.0, 70.0)])


def _dome_and_wall(rho: float, x_wall: float) -> Part:
    """The upper hemisphere of radius rho about the origin (convex, normals out), beside the wall
    x = x_wall (moved by OFFSET)."""
    circle = [(1, 0, 1), (1, 1, _S), (0, 1, 1), (-1, 1, _S), (-1, 0, 1), (-1, -1, _S), (0, -1, 1),
              (1, -1, _S), (1, 0, 1)]
    arc = [(1, 0, 1), (1, 1, _S), (0, 1, 1)]  # (radial, height, w): equator -> top
    P = np.array([[(x * a, y * a, h) for a, h, _ in arc] for x, y, _ in circle], dtype=float)
    W = np.array([[wc * wa for _, _, wa in arc] for _, _, wc in circle], dtype=float)
    g = geomdl_surface(rho * P, W, (2, 2), [0, 0, 0, .25, .25, .5, .5, .75, .75, 1, 1, 1],
                       [0, 0, 0, 1, 1, 1])
    return _moved([facing_up(to_surface(g, 0, name="dome")), _wall(x_wall, 70.0, -10.0, 80.0)])


def _on_samples(tp, keep, count: int = 16) -> np.ndarray:
    """Up to `count` test points of surface 0 (the CC points) where `keep(points - OFFSET,
    normals)` holds, evenly spread over them."""
    idx = np.flatnonzero(tp.surface == 0)
    idx = idx[keep(tp.points[idx] - OFFSET, tp.normals[idx])]
    assert idx.size >= count // 2
    return idx[np.unique(np.linspace(0, idx.size - 1, count).astype(int))]


def _wall_truth(c, cc: np.ndarray, n: np.ndarray, x_wall: float) -> np.ndarray:
    """The size at which the cutter touching cc (part frame less OFFSET) with normal n reaches
    the wall x = x_wall (module docstring)."""
    if c.kind == "ball":
        return (x_wall - cc[:, 0]) / (1.0 + n[:, 0])
    r = float(c.r)
    h = np.hypot(n[:, 0], n[:, 1])
    e_x = n[:, 0] / h
    return (x_wall - cc[:, 0] - r * n[:, 0] - r) / (1.0 + e_x)


def _check(part: Part, c, idx: np.ndarray, truth: np.ndarray) -> None:
    tp = sample_part(part)
    cc, n = tp.points[idx], tp.normals[idx]
    assert np.array_equal(cc, tp.points[idx])  # the CC points are test points
    for kw in ({}, dict(cc_surface=tp.surface[idx], cc_uv=tp.uv[idx])):
        res = allowable(tp, part, c, cc, n, **kw)
        err = np.abs(res.size - truth)
        assert err.max() < TOL, (kw.keys(), res.size[err >= TOL], truth[err >= TOL])
        assert np.all(res.advice != "inaccessible")


@pytest.mark.parametrize("cut", CUTTERS)
def test_tilted_plane_beside_a_wall(cut):
    """The issue's case: a tilted plane (20 degrees) beside a wall 25 mm away, CC points on the
    plane's test points; sizes came out 0 at CC points whose neighbours on the grid lines lie
    above the tangent plane by rounding."""
    x_wall = 25.0
    part = _plane_and_wall(np.radians(20.0), x_wall)
    c = parse_cutter(cut)
    idx = _on_samples(sample_part(part),
                      lambda p, n: (np.abs(p[:, 0]) <= 12) & (p[:, 1] >= 0) & (p[:, 1] <= 20))
    tp = sample_part(part)
    truth = _wall_truth(c, tp.points[idx] - OFFSET, tp.normals[idx], x_wall)
    _check(part, c, idx, truth)


@pytest.mark.parametrize("cut", CUTTERS)
def test_horizontal_floor_beside_a_wall(cut):
    """A horizontal floor: its test points' heights differ from the CC point's by rounding; a
    flat-bottomed cutter then took floor points as cut (sizes of half their distance)."""
    x_wall = 25.0
    part = _plane_and_wall(0.0, x_wall)
    c = parse_cutter(cut)
    tp = sample_part(part)
    idx = _on_samples(tp, lambda p, n: (np.abs(p[:, 0]) <= 12) & (np.abs(p[:, 1]) <= 15))
    x = tp.points[idx, 0] - OFFSET[0]
    truth = x_wall - x if c.kind == "ball" else 0.5 * (x_wall - x - float(c.r))
    _check(part, c, idx, truth)


@pytest.mark.parametrize("cut", CUTTERS)
def test_convex_cylinder_beside_a_wall(cut):
    """Along a convex cylinder's rulings the points lie in the CC point's tangent plane."""
    x_wall = 25.0
    part = _cylinder_and_wall(10.0, x_wall)
    c = parse_cutter(cut)
    tp = sample_part(part)
    idx = _on_samples(tp, lambda p, n: (np.abs(p[:, 0]) <= 12) & (np.abs(n[:, 1]) >= 0.1)
                      & (np.abs(n[:, 1]) <= 0.9))
    truth = _wall_truth(c, tp.points[idx] - OFFSET, tp.normals[idx], x_wall)
    _check(part, c, idx, truth)


@pytest.mark.parametrize("cut", CUTTERS)
def test_convex_sphere_beside_a_wall(cut):
    x_wall = 30.0
    part = _dome_and_wall(10.0, x_wall)
    c = parse_cutter(cut)
    tp = sample_part(part)
    idx = _on_samples(tp, lambda p, n: (n[:, 0] >= -0.3) & (n[:, 2] >= 0.3) & (n[:, 2] <= 0.95))
    truth = _wall_truth(c, tp.points[idx] - OFFSET, tp.normals[idx], x_wall)
    _check(part, c, idx, truth)


@pytest.mark.parametrize("cut", ["CUTTER/10,5", "CUTTER/12,2"])
@pytest.mark.parametrize("shape", ["bowl", "groove"])
def test_concave_sphere_and_cylinder(cut, shape):
    rho = 20.0 if shape == "bowl" else 15.0
    part = bowl(rho)[0] if shape == "bowl" else groove(rho, 80.0)[0]
    part = _moved(part.surfaces)
    c = parse_cutter(cut)
    tp = sample_part(part)
    idx = _on_samples(tp, lambda p, n: (n[:, 2] >= 0.3) & (n[:, 2] <= 0.95)
                      & (np.abs(p[:, 0]) <= 30))
    phi = np.arccos(np.clip(tp.normals[idx, 2], -1, 1))
    truth = np.full(idx.size, rho) if c.kind == "ball" else (rho - float(c.r)) * np.sin(phi)
    _check(part, c, idx, truth)
