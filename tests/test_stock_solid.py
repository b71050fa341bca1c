"""A closed triangle mesh as Z-dexels (`checker.stock.solid`): against the analytic intervals of
a box, a sphere, a torus standing up (two intervals per ray), an octahedron whose edges and
vertices fall exactly on rays, and a real STL of known volume."""

from __future__ import annotations

import numpy as np
import pytest

from checker.config import default_config
from checker.errors import PathcheckError
from checker.stock.solid import load_solid, require_closed, solid_dexels


def box_mesh(lo, hi):
    """The 12 outward triangles of the box [lo, hi]."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1])
                  for x in (lo[0], hi[0])])
    f = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                  [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])
    return v, f


def grid_surface(point, nu, nv, wrap_v):
    """Triangles of the (u, v) grid of `point(u, v)`, u periodic in nu, v in nv rows (periodic
    when `wrap_v`)."""
    rows = nv if wrap_v else nv + 1
    u, v = np.meshgrid(np.arange(nu), np.arange(rows), indexing="ij")
    verts = point(u.ravel() / nu, v.ravel() / nv)
    idx = lambda a, b: (a % nu) * rows + (b % rows)  # noqa: E731
    a, b = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a, b = a.ravel(), b.ravel()
    quads = np.column_stack([idx(a, b), idx(a + 1, b), idx(a + 1, b + 1), idx(a, b + 1)])
    tris = np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return verts, tris


def sphere_mesh(r, nu=96, nv=48):
    """A UV sphere of radius r at the origin (its poles' degenerate triangles included)."""
    def point(s, t):
        th, ph = np.pi * t, 2 * np.pi * s
        return r * np.column_stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    return grid_surface(point, nu, nv, wrap_v=False)


def torus_mesh(R, r, nu=128, nv=48):
    """A torus standing up: its ring in the XZ plane about the Y axis."""
    def point(s, t):
        u, v = 2 * np.pi * s, 2 * np.pi * t
        rho = R + r * np.cos(v)
        return np.column_stack([rho * np.cos(u), r * np.sin(v), rho * np.sin(u)])
    return grid_surface(point, nu, nv, wrap_v=True)


def mesh_volume(v, f):
    """The divergence theorem's volume of a closed mesh (either orientation)."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return abs(float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0))


def lengths(d):
    slot = np.arange(d.capacity)[None, None, :] < d.count[:, :, None]
    return np.where(slot, d.hi.astype(float) - d.lo, 0.0).sum(axis=2)


def test_box():
    v, f = box_mesh([-1.0, -2.0, 3.0], [2.0, 1.0, 4.5])
    d = solid_dexels(v, f, -3.0, -3.0, 24, 24, 0.25)
    inside = (np.abs(d.xs() - 0.5)[None, :] < 1.5) & (np.abs(d.ys() + 0.5)[:, None] < 1.5)
    assert (d.count == inside).all() and d.unclosed == 0 and d.overflow == 0
    assert (d.lo[inside, 0] == 3.0).all() and (d.hi[inside, 0] == 4.5).all()
    assert d.volume() == pytest.approx(3 * 3 * 1.5, rel=1e-12)


def test_sphere_rays_and_volume():
    """Every ray's interval lies between the polyhedron's in-sphere and the sphere; the volume
    is within the bound h A / sqrt(2) of the polyhedron's (the dexel solid differs from the
    solid only within h / sqrt(2) across the surface, area A) and the polyhedron's within its
    own chord deviation of 4/3 pi r^3."""
    r, h = 10.0, 0.2
    v, f = sphere_mesh(r)
    n = int(np.ceil(2.4 * r / h))
    d = solid_dexels(v, f, -1.2 * r, -1.2 * r, n, n, h)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    normal = np.cross(b - a, c - a)
    area2 = np.linalg.norm(normal, axis=1)
    keep = area2 > 1e-12
    r_in = float(np.min(np.abs(np.einsum("ij,ij->i", normal[keep], a[keep])) / area2[keep]))
    rho = np.hypot(*np.meshgrid(d.xs(), d.ys()))
    assert d.unclosed == 0 and d.count.max() == 1
    assert (d.count[rho < r_in] == 1).all() and (d.count[rho > r] == 0).all()
    m = d.count == 1
    z_out = np.sqrt(np.maximum(r * r - rho[m] ** 2, 0.0))
    z_in = np.sqrt(np.maximum(r_in * r_in - rho[m] ** 2, 0.0))
    tol = 1e-5  # float32
    assert (d.hi[m, 0] <= z_out + tol).all() and (d.hi[m, 0] >= z_in - tol).all()
    assert (d.lo[m, 0] >= -z_out - tol).all() and (d.lo[m, 0] <= -z_in + tol).all()
    v_mesh = mesh_volume(v, f)
    area = 0.5 * area2.sum()
    assert abs(d.volume() - v_mesh) <= h * area / np.sqrt(2)
    sphere = 4.0 / 3.0 * np.pi * r**3
    assert sphere * (r_in / r) ** 3 <= v_mesh <= sphere
    assert abs(d.volume() - sphere) <= h * area / np.sqrt(2) + (sphere - v_mesh)
    # the midpoint rule does far better than the bound: 0.2% here
    assert d.volume() == pytest.approx(v_mesh, rel=2e-3)


def test_torus_standing_up_has_two_intervals_per_ray():
    """A vertical ray at (x, y) through the ring (major R about Y, minor r) meets the tube where
    sqrt(x^2 + z^2) is in [R - s, R + s], s = sqrt(r^2 - y^2): two intervals when |x| < R - s."""
    R, r, h = 10.0, 3.0, 0.25
    v, f = torus_mesh(R, r)
    d = solid_dexels(v, f, -14.0, -4.0, 112, 32, h)
    X, Y = np.meshgrid(d.xs(), d.ys())
    s = np.sqrt(np.maximum(r * r - Y**2, 0.0))
    two = (np.abs(Y) < r - 0.2) & (np.abs(X) < R - s - 0.5)
    assert d.unclosed == 0 and d.overflow == 0
    assert two.sum() > 500 and (d.count[two] == 2).all()
    top = np.sqrt((R + s[two]) ** 2 - X[two] ** 2)
    assert np.abs(d.hi[two, 1] - top).max() < 0.05  # the mesh's chords: r (1 - cos(pi / 48))
    assert np.abs(d.lo[two, 0] + top).max() < 0.05
    torus = 2 * np.pi**2 * R * r * r
    assert d.volume() == pytest.approx(mesh_volume(v, f), rel=5e-3)
    assert d.volume() == pytest.approx(torus, rel=1e-2)


def test_rays_exactly_on_edges_and_vertices_count_once():
    """The octahedron |x| + |y| + |z| <= 1 on rays every 0.5 from -1 to 1: its apexes, its
    edges (the axes in projection) and its equator's vertices fall on rays. Each ray inside has
    exactly [-(1 - |x| - |y|), 1 - |x| - |y|], on the rim nothing; never an odd count."""
    v = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4],
                  [1, 0, 5], [2, 1, 5], [3, 2, 5], [0, 3, 5]])
    for x0, h, n in ((-1.25, 0.5, 5), (-1.125, 0.25, 9), (-1.0625, 0.125, 17)):
        d = solid_dexels(v, f, x0, x0, n, n, h)
        X, Y = np.meshgrid(d.xs(), d.ys())
        half = 1.0 - np.abs(X) - np.abs(Y)
        assert d.unclosed == 0
        np.testing.assert_array_equal(d.count, half > 1e-12)
        np.testing.assert_allclose(d.hi[half > 0, 0], half[half > 0], atol=1e-6)
        np.testing.assert_allclose(d.lo[half > 0, 0], -half[half > 0], atol=1e-6)
    # the box's top and bottom split on their diagonals, rays on the diagonals and on its rim
    vb, fb = box_mesh([-1, -1, -1], [1, 1, 1])
    d = solid_dexels(vb, fb, -1.5, -1.5, 7, 7, 0.5)
    assert d.unclosed == 0 and set(np.unique(d.count)) <= {0, 1}
    assert (d.count[1:6, 1:6][1:4, 1:4] == 1).all()  # the inner rays, the diagonals' included
    assert ((d.hi[d.count == 1, 0] == 1) & (d.lo[d.count == 1, 0] == -1)).all()


def test_more_intervals_than_the_capacity_fold_into_the_last():
    boxes = [box_mesh([0, 0, z], [1, 1, z + 1]) for z in (0, 2, 4, 6, 8)]
    v = np.vstack([b[0] for b in boxes])
    f = np.vstack([b[1] + 8 * k for k, b in enumerate(boxes)])
    d = solid_dexels(v, f, 0.0, 0.0, 2, 2, 0.5, capacity=3)
    assert (d.count == 3).all() and d.overflow == 4
    np.testing.assert_array_equal(d.lo[0, 0], [0, 2, 4])
    np.testing.assert_array_equal(d.hi[0, 0], [1, 3, 9])


def test_an_open_mesh_is_refused():
    v, f = box_mesh([0, 0, 0], [1, 1, 1])
    d = solid_dexels(v, f[2:], -0.5, -0.5, 4, 4, 0.5)  # the bottom removed
    assert d.unclosed == 4
    with pytest.raises(PathcheckError, match="not closed"):
        require_closed(d, "sheet.stl")
    require_closed(solid_dexels(v, f, -0.5, -0.5, 4, 4, 0.5), "box.stl")


def test_spinner_demo_stl_volume(realdata):
    """Spinner_Demo.stl (asmbl-fusion360-gcode): 6,580.39 mm^3 by its SOURCES.txt, 50 x 32 x
    10 mm; at h = 0.1 within h A / sqrt(2) (A = 3,644.97 mm^2), and in fact within 0.3%."""
    path = realdata / "asmbl-fusion360-gcode" / "Spinner_Demo.stl"
    v, f = load_solid(path, default_config())
    h = 0.1
    d = solid_dexels(v, f, -25.2, -16.2, 504, 324, h)
    require_closed(d, path)
    assert d.unclosed == 0
    assert abs(d.volume() - 6580.39) <= h * 3644.97 / np.sqrt(2)
    assert d.volume() == pytest.approx(6580.39, rel=3e-3)
    top = d.hi[:, :, 0][d.count > 0]
    assert top.max() == pytest.approx(10.0, abs=1e-5) and d.lo[d.count > 0, 0].min() == 0.0


def test_load_solid_names_the_file_as_what_it_is(tmp_path):
    bad = tmp_path / "jaw.stl"
    bad.write_bytes(b"not an stl at all")
    with pytest.raises(PathcheckError) as err:
        load_solid(bad, default_config(), what="fixture")
    assert "fixture" in str(err.value) and "jaw.stl" in str(err.value)
    with pytest.raises(PathcheckError, match="fixture"):
        load_solid(tmp_path / "missing.step", default_config(), what="fixture")
