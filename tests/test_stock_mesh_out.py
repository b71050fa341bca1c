"""The dexel stock written as STL (`checker.stock.mesh_out`), read back by trimesh (an
independent reader): closed, and of the dexels' own volume."""

from __future__ import annotations

import numpy as np
import pytest
from requires import require_extra

from checker.errors import PathcheckError
from checker.stock.dexels import Dexels
from checker.stock.mesh_out import most_triangles, stock_triangles, write_stl

trimesh = require_extra("trimesh", "test")


def block(nx, ny, h, lo, hi, x0=-3.0, y0=2.0):
    d = Dexels.empty(x0, y0, nx, ny, h)
    d.count[:] = 1
    d.lo[:, :, 0], d.hi[:, :, 0] = lo, hi
    return d


def read_back(d, tmp_path, name="stock.stl"):
    path = write_stl(d, tmp_path / name)
    return trimesh.load(path, force="mesh", process=True)


def balanced(tri: np.ndarray) -> bool:
    """Every directed edge (vertices by their float32 position) matched by its reverse as often:
    a closed, consistently oriented surface (edges of four faces included)."""
    pts = tri.astype(np.float32).reshape(-1, 3)
    _, ids = np.unique(pts, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 3)
    edges = np.concatenate([ids[:, [0, 1]], ids[:, [1, 2]], ids[:, [2, 0]]])
    fwd = np.unique(edges, axis=0, return_counts=True)
    back = np.unique(edges[:, ::-1], axis=0, return_counts=True)
    return all(np.array_equal(a, b) for a, b in zip(fwd, back, strict=True))


def test_box(tmp_path):
    d = block(20, 10, 0.5, -5.0, 3.0)
    m = read_back(d, tmp_path)
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(d.volume(), rel=1e-6) and d.volume() == pytest.approx(400)
    np.testing.assert_allclose(m.bounds, [[-3, 2, -5], [7, 7, 3]], atol=1e-5)
    # the tops and bottoms (2 x 200 quads), the outside walls (60 quads), nothing inside
    assert len(m.faces) == 2 * (2 * 200 + 60)


def test_box_with_a_slot_and_a_pocket(tmp_path):
    d = block(24, 16, 0.25, 0.0, 4.0)
    d.hi[:, 10:14, 0] = 2.5  # a slot through along Y, 1.5 deep
    d.hi[3:7, 2:6, 0] = 1.0  # a pocket 3 deep
    d.count[12:14, 18:20] = 0  # a hole through
    m = read_back(d, tmp_path)
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(d.volume(), rel=1e-6)
    expected = 24 * 16 * 4.0 - 16 * 4 * 1.5 - 16 * 3.0 - 4 * 4.0
    assert d.volume() == pytest.approx(expected * 0.25**2)
    faces = np.sort(m.faces, axis=1)
    assert len(np.unique(faces, axis=0)) == len(faces)  # no face twice
    # no face inside the material: every face's centre lies on the dexels' surface
    c = m.triangles_center
    assert np.isclose(c[:, 2], 0).sum() + np.isclose(c[:, 2], 4).sum() + np.isclose(
        c[:, 2], 2.5).sum() + np.isclose(c[:, 2], 1).sum() + (np.abs(m.face_normals[:, 2]) < 1e-6
                                                             ).sum() == len(c)


def test_a_ray_with_two_intervals_and_a_closed_void(tmp_path):
    one = Dexels.empty(0.0, 0.0, 1, 1, 2.0)
    one.count[0, 0] = 2
    one.lo[0, 0, :2], one.hi[0, 0, :2] = [0.0, 2.0], [1.0, 4.0]
    m = read_back(one, tmp_path, "two.stl")
    assert m.is_watertight and m.volume == pytest.approx(12.0) and len(m.faces) == 24
    assert len(m.split(only_watertight=True)) == 2
    void = block(3, 3, 1.0, 0.0, 4.0)
    void.count[1, 1] = 2
    void.lo[1, 1, :2], void.hi[1, 1, :2] = [0.0, 2.0], [1.0, 4.0]  # a cavity at z 1..2
    m = read_back(void, tmp_path, "void.stl")
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(35.0) and void.volume() == pytest.approx(35.0)


def test_a_staircase_with_four_heights_at_every_corner(tmp_path):
    """Tops rising along X and Y by incommensurate steps: each corner meets four heights, each
    wall's ends are split at points of the other walls (no vertex inside an edge)."""
    d = block(12, 9, 0.5, 0.0, 1.0)
    j, i = np.mgrid[0:9, 0:12]
    d.hi[:, :, 0] = 1.0 + 0.3 * i + 0.17 * j
    m = read_back(d, tmp_path)
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(d.volume(), rel=1e-6)


def test_random_dexels_are_closed_with_their_volume(tmp_path):
    """Random intervals (some touching, some empty, diagonal neighbours): every directed edge
    is matched by its reverse, and trimesh's volume is the dexels'."""
    rng = np.random.default_rng(41)
    d = Dexels.empty(1.0, -2.0, 15, 11, 0.4)
    ends = np.sort(rng.choice(np.arange(0.0, 5.0, 0.25), size=(11, 15, 8)), axis=2)
    d.lo[:], d.hi[:] = ends[:, :, 0::2], ends[:, :, 1::2]
    d.count[:] = rng.integers(0, 5, size=(11, 15))
    tri = stock_triangles(d)
    assert balanced(tri)
    assert len(tri) <= most_triangles(d)  # the room write_stl reserves
    m = read_back(d, tmp_path)
    assert m.volume == pytest.approx(d.volume(), rel=1e-6)


def test_empty_stock_and_a_bad_target(tmp_path):
    empty = Dexels.empty(0.0, 0.0, 3, 3, 1.0)
    assert stock_triangles(empty).shape == (0, 3, 3)
    from stl import mesh as stl_mesh

    path = write_stl(empty, tmp_path / "empty.stl")
    assert len(stl_mesh.Mesh.from_file(str(path)).vectors) == 0
    with pytest.raises(PathcheckError, match="stock STL"):
        write_stl(block(2, 2, 1.0, 0.0, 1.0), tmp_path / "no" / "such" / "folder.stl")
