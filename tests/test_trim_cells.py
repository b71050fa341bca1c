"""The triangles of a trimmed surface tile its kept region whole (`geometry.trim_cells`): a
plane of 100 x 40 mm with a circular hole, a notch and a strip narrower than a grid cell,
against the region's analytic area and against points sampled inside the trim; a cylinder
trimmed by a band across its seam."""

import numpy as np
import pytest
import shapely

from checker.config import load_config
from checker.geometry.evaluate import evaluate
from checker.geometry.primitives import flat_patch, nurbs_cylinder
from checker.geometry.tessellate import part_triangles
from checker.geometry.trim_cells import kept_region, trimmed_grid
from checker.geometry.trims import UVTrim
from checker.part import Part

_CFG = load_config(None)


def _circle(cx: float, cy: float, r: float, n: int = 720) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])


def _plate() -> Part:
    """100 x 40 mm in (x, y) at z = 0 (u along x, v along y, both 0..1), kept: an outer
    polygon with a notch and a thin arm (a strip 0.2 mm wide: 0.002 in u), a hole of radius 8
    mm at (30, 20)."""
    s = flat_patch([0, 0, 0], [100, 0, 0], [0, 40, 0])
    outer = np.array([[0.05, 0.05], [0.7, 0.05], [0.7, 0.5], [0.9, 0.5], [0.9, 0.05],
                      [0.95, 0.05], [0.95, 0.95], [0.601, 0.95], [0.601, 0.6], [0.599, 0.6],
                      [0.599, 0.95], [0.05, 0.95]])
    hole = _circle(0.0, 0.0, 1.0) * [0.08, 0.2] + [0.3, 0.5]  # r 8 mm in (x, y)
    s.trim = UVTrim([outer, hole])  # even-odd: the hole cancels inside the outer loop
    return Part(surfaces=[s], source="plate", content_hash="plate-trim-cells")


def _area_3d(tris) -> float:
    v = tris.vertices[tris.triangles]
    return 0.5 * float(np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]),
                                      axis=1).sum())


def _uv_triangle_of(uv_tri: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whether each point q (M, 2) lies in one of the (T, 3, 2) triangles (closed)."""
    tree = shapely.STRtree(shapely.polygons(uv_tri))
    hits = tree.query(shapely.points(q), predicate="intersects")
    inside = np.zeros(len(q), dtype=bool)
    inside[hits[0]] = True
    return inside


def test_plate_area_is_the_trimmed_region_exactly():
    part = _plate()
    tris = part_triangles(part, _CFG.check.part_deviation, _CFG.geometry)
    region_uv = kept_region(part.surfaces[0]).area
    assert _area_3d(tris) == pytest.approx(region_uv * 100.0 * 40.0, rel=1e-9)
    # the analytic kept area: the polygon less the hole (an inscribed 720-gon of the circle)
    polygon = shapely.Polygon(part.surfaces[0].trim.outer[0]).area * 4000.0
    hole = 0.5 * 720 * 8.0**2 * np.sin(2.0 * np.pi / 720)
    assert _area_3d(tris) == pytest.approx(polygon - hole, rel=1e-9)


def test_every_point_inside_the_trim_is_on_a_triangle():
    """Points inside the trim (the part's own classifier), many of them in the 0.2 mm strip and
    along the trim loops, each inside a triangle in (u, v) and at most the stated deviation
    from the triangles in space. The grid's cells are 1 mm and more: a cell kept only when its
    four corners are inside the trim leaves the strip and a band along every loop uncovered."""
    part = _plate()
    s = part.surfaces[0]
    tris = part_triangles(part, _CFG.check.part_deviation, _CFG.geometry)
    rng = np.random.default_rng(3)
    q = np.concatenate([rng.uniform(0, 1, (20000, 2)),
                        np.column_stack([rng.uniform(0.599, 0.601, 2000),
                                         rng.uniform(0.6, 0.95, 2000)])])
    q = q[s.trim.contains(q[:, 0], q[:, 1])]
    assert (q[:, 0] > 0.599).sum() > 1000
    covered = _uv_triangle_of(tris.uv[tris.triangles], q)
    assert covered.all(), f"{(~covered).sum()} of {len(q)} trimmed points on no triangle"


def test_cylinder_band_across_the_seam():
    """A band around a cylinder R 15 (v from 0.3 to 0.45 of its height, all the way round
    and across the seam u = 0 = 1): the triangles' area is the band's, within the chord
    deviation's share, and every vertex is on the cylinder."""
    s = nurbs_cylinder(15.0, 0.0, 50.0)
    band = np.array([[0.0, 0.3], [1.0, 0.3], [1.0, 0.45], [0.0, 0.45]])
    s.trim = UVTrim([band])
    part = Part(surfaces=[s], source="band", content_hash="cylinder-band")
    tris = part_triangles(part, _CFG.check.part_deviation, _CFG.geometry)
    radial = np.hypot(tris.vertices[:, 0], tris.vertices[:, 1])
    np.testing.assert_allclose(radial, 15.0, atol=1e-9)
    z = tris.vertices[:, 2]
    assert z.min() == pytest.approx(15.0, abs=1e-9) and z.max() == pytest.approx(22.5, abs=1e-9)
    # inscribed polygon of the circle: a little less than 2 pi R h, never more
    exact = 2.0 * np.pi * 15.0 * 7.5
    assert exact * (1 - 2 * tris.typical / 15.0) <= _area_3d(tris) <= exact


def test_triangles_do_not_overlap_in_uv():
    """The pieces of the clipped cells and the whole cells tile the region: their (u, v) areas
    add up to the region's, and the union's area is the same (no overlap)."""
    s = _plate().surfaces[0]
    uv, tri = trimmed_grid(s, np.linspace(0, 1, 23), np.linspace(0, 1, 17))
    polys = shapely.polygons(uv[tri])
    total = shapely.area(polys).sum()
    assert total == pytest.approx(kept_region(s).area, rel=1e-12)
    assert shapely.union_all(polys).area == pytest.approx(total, rel=1e-9)
    # counter-clockwise: du x dv is their normal
    e1, e2 = uv[tri[:, 1]] - uv[tri[:, 0]], uv[tri[:, 2]] - uv[tri[:, 0]]
    assert (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0).all()
    pts = evaluate(s, uv[:, 0], uv[:, 1]).points
    assert np.isfinite(pts).all()
