"""Test-point sampling: coverage for the sag and spacing limits, trims honoured, mesh parts,
cache, and (surface, u, v) that reproduce every point."""

from __future__ import annotations

import json

import numpy as np
import pytest

from checker.config import GeometryConfig
from checker.geometry import load_part
from checker.geometry.evaluate import evaluate, evaluate_mixed
from checker.geometry.primitives import flat_patch, nurbs_cylinder, nurbs_sphere
from checker.geometry.sampling import sample_part
from checker.part import Part


def _random_on(surface, n, rng):
    (u0, u1), (v0, v1) = surface.domain
    u, v = rng.uniform(u0, u1, n), rng.uniform(v0, v1, n)
    return u, v, evaluate(surface, u, v).points


@pytest.mark.parametrize("sag", [0.05, 0.005])
def test_every_surface_point_is_near_a_test_point(sag):
    part = Part(surfaces=[nurbs_sphere(6.0, surface_id=0), nurbs_cylinder(20.0, 0, 15, 1)])
    cfg = GeometryConfig(max_spacing=50.0)  # only the sag limit applies
    tp = sample_part(part, sag=sag, geometry=cfg)
    rng = np.random.default_rng(4)
    for s in part.surfaces:
        _, _, pts = _random_on(s, 20000, rng)
        dist, idx = tp.tree.query(pts)
        assert np.all(dist <= 0.5 * tp.spacing[idx] + sag + 1e-9)
    # the chord between neighbouring samples of a circle of radius R sags h^2 / (8 R) <= sag
    ring = tp.points[(tp.surface == 1) & (np.abs(tp.uv[:, 1]) < 1e-12)]
    ang = np.sort(np.arctan2(ring[:, 1], ring[:, 0]))
    chord_sag = 20.0 * (1 - np.cos(np.diff(ang).max() / 2))
    assert chord_sag <= sag and chord_sag > sag / 4  # dense enough, not wastefully so


def test_spacing_limit_and_uv_reproduce_points():
    plate = flat_patch([0, 0, 0], [30, 0, 0], [0, 20, 0])
    cfg = GeometryConfig(max_spacing=0.5)
    tp = sample_part(Part(surfaces=[plate]), geometry=cfg)
    # a flat plate needs no points for sag: the spacing limit alone sets 61 x 41 samples
    assert len(tp.points) == 61 * 41
    assert np.allclose(tp.spacing, np.hypot(0.5, 0.5))
    again = evaluate_mixed(Part(surfaces=[plate]), tp.surface, tp.uv[:, 0], tp.uv[:, 1])
    assert np.array_equal(again.points, tp.points) and np.array_equal(again.normals, tp.normals)
    assert np.allclose(tp.normals, [0, 0, 1])


def test_samples_are_cached_by_content_hash():
    part = Part(surfaces=[nurbs_sphere(3.0)])
    twin = Part(surfaces=[nurbs_sphere(3.0)])
    assert part.content_hash == twin.content_hash
    assert sample_part(part) is sample_part(twin)
    assert sample_part(part, sag=0.01) is not sample_part(part)


def _floor_with_opening(tmp_path, keep_inside: bool):
    """A 100 x 100 floor at z = 0 with a trim loop around [40, 60]^2 (uv = xy / 100)."""
    sq = [[0.4, 0.4], [0.6, 0.4], [0.6, 0.6], [0.4, 0.6], [0.4, 0.4]]
    floor = {
        "type": "spline", "degree_u": 1, "degree_v": 1, "size_u": 2, "size_v": 2,
        "knotvector_u": [0, 0, 1, 1], "knotvector_v": [0, 0, 1, 1],
        "control_points": {"points": [[0, 0, 0], [0, 100, 0], [100, 0, 0], [100, 100, 0]]},
        "trims": {"count": 1, "data": [
            {"type": "spline", "degree": 1, "knotvector": [0, 0, 0.25, 0.5, 0.75, 1, 1],
             "control_points": {"points": sq}, "reversed": int(keep_inside)}]},
    }  # fmt: skip
    path = tmp_path / f"floor_{int(keep_inside)}.json"
    path.write_text(json.dumps({"shape": {"type": "surface", "count": 1, "data": [floor]}}))
    return load_part(path)


def test_trimmed_away_opening_yields_no_test_points(tmp_path):
    """The untrimmed floor extends across the opening the tool plunges through: no test point
    may come from there, but the rim of the opening is sampled."""
    part = _floor_with_opening(tmp_path, keep_inside=False)
    assert part.surfaces[0].trim is not None
    tp = sample_part(part)
    x, y = tp.points[:, 0], tp.points[:, 1]
    inside = (x > 40 + 1e-9) & (x < 60 - 1e-9) & (y > 40 + 1e-9) & (y < 60 - 1e-9)
    assert not inside.any()
    rim = np.maximum(np.abs(x - 50), np.abs(y - 50))
    assert np.sum(np.abs(rim - 10) < 1e-9) >= 80  # boundary samples about 0.5 mm apart
    assert len(tp.points) > 9000  # the rest of the floor is there


def test_reversed_trim_keeps_only_the_inside(tmp_path):
    tp = sample_part(_floor_with_opening(tmp_path, keep_inside=True))
    assert tp.points[:, :2].min() >= 40 - 1e-9 and tp.points[:, :2].max() <= 60 + 1e-9


def test_stl_samples_are_the_vertices(realdata):
    """A mesh part's test points are its vertices (the exact checks use the triangles, so no
    lattice of points: memory in O(triangles)), each with its longest edge as spacing: every
    point of a triangle lies within that of one of its vertices."""
    part = load_part(realdata / "bladex-propeller-iges" / "upper.stl")
    tp = sample_part(part, geometry=GeometryConfig(max_spacing=1.0))
    assert np.all(tp.surface == -1) and np.isnan(tp.uv).all()
    assert np.allclose(np.linalg.norm(tp.normals, axis=1), 1.0)
    np.testing.assert_array_equal(tp.points, part.mesh.vertices)
    rng = np.random.default_rng(0)
    tri = part.mesh.vertices[part.mesh.triangles]
    b = rng.dirichlet([1, 1, 1], len(tri))
    pts = np.einsum("tc,tcx->tx", b, tri)
    near = np.linalg.norm(tri - pts[:, None], axis=2).min(axis=1)
    corner = part.mesh.triangles[np.arange(len(tri)),
                                 np.linalg.norm(tri - pts[:, None], axis=2).argmin(axis=1)]
    assert np.all(near <= tp.spacing[corner] + 1e-9)
