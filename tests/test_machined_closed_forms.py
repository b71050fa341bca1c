"""The machined part against the design (checker/machined, docs/MATH.md §15) against closed
forms: a ball-nose raster's scallop, a facing pass's left stock, a plunge's over-cut, and the
deviation kernel against a brute-force point-membership walk."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from checker.cutter import Cutter
from checker.machined.compare import Comparison
from checker.machined.deviation import error_bound, signed_deviation
from checker.machined.points import surface_mesh
from checker.mesh.tool import tool_pieces
from checker.stock.dexels import Dexels
from checker.stock.removal import remove

Z = np.array([0.0, 0.0, 1.0])


def _plane(x0, y0, x1, y1, z, spacing):
    V = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], float)
    T = np.array([[0, 1, 2], [0, 2, 3]])
    return surface_mesh(V, T, np.full(2, -1), spacing)


def _cut(stock, cutter, path, step=0.05):
    p = np.asarray(path, float)
    a, b = p[:-1], p[1:]
    remove(stock, tool_pieces(cutter, with_holder=False), a, b, np.tile(Z, (len(a), 1)),
           np.arange(len(a)), len(a), step=step)


def test_ball_raster_leaves_the_analytic_scallop():
    h, R, s = 0.05, 3.0, 1.2                     # step-over s a multiple of 2h: cusps on rays
    stock = Dexels.box([0, 0, -2], [20, 12, 1], h)
    ball = Cutter("ball", d=2 * R, r=R, R=0.0, flute_length=10.0)
    path = []
    ys = 0.025 + np.arange(-2, 13) * s           # pass centres on ray centres
    for k, y in enumerate(ys):
        xa, xb = (-5.0, 25.0) if k % 2 == 0 else (25.0, -5.0)
        path += [[xa, y, 0.0], [xb, y, 0.0]]     # ball tip on the design plane z = 0
    V = np.array([[2, 2, 0], [18, 2, 0], [18, 10, 0], [2, 10, 0]], float)
    part = SimpleNamespace(vertices=V, triangles=np.array([[0, 1, 2], [0, 2, 3]]),
                           surface=np.full(2, -1))
    cmp = Comparison(part, None, stock, {}, np.array([0.001]), np.zeros(1), 1e-6, spacing=h)
    _cut(stock, ball, path)
    cmp.after(0, stock)
    mesh = _plane(2, 2, 18, 10, 0.0, h)
    dev = signed_deviation(stock, mesh.vertices, mesh.normals, 5.0, 5.0)
    scallop = R - math.sqrt(R * R - (s / 2) ** 2)
    # the operation's record: every point cut, the scallop its step-over leaves
    op = cmp.ops[0]
    assert op.points_cut == len(cmp.mesh.vertices)
    assert op.left_max == pytest.approx(scallop, abs=1e-4)
    assert op.overcut_max <= 1e-5
    bound = error_bound(1e-6, h, mesh.normals)
    assert np.all(dev >= -1e-5)                  # a tangent raster never cuts below
    assert dev.max() == pytest.approx(scallop, abs=1e-4 + bound.max())
    # every point against the analytic cusp of its ray (the column's centre)
    ry = stock.y0 + (np.floor((mesh.vertices[:, 1] - stock.y0) / h) + 0.5) * h
    e = np.abs(ry - ys[np.argmin(np.abs(ry[:, None] - ys[None, :]), axis=1)])
    assert np.allclose(dev, R - np.sqrt(R * R - e * e), atol=1e-4)


def test_facing_pass_above_the_design_leaves_exactly_its_depth():
    h, d = 0.1, 0.37
    stock = Dexels.box([0, 0, -5], [30, 20, 2], h)
    flat = Cutter("flat", d=10.0, r=0.0, R=5.0, flute_length=25.0)
    path = []
    for k, y in enumerate(np.arange(-3.0, 24.0, 6.0)):
        xa, xb = (-8.0, 38.0) if k % 2 == 0 else (38.0, -8.0)
        path += [[xa, y, d], [xb, y, d]]
    _cut(stock, flat, path)
    mesh = _plane(1, 1, 29, 19, 0.0, 0.5)
    dev = signed_deviation(stock, mesh.vertices, mesh.normals, 10.0, 5.0)
    assert np.allclose(dev, d, atol=1e-5)


def test_plunge_too_deep_is_an_overcut_of_its_depth_where_it_plunged():
    h = 0.05
    stock = Dexels.box([0, 0, -5], [20, 20, 0], h)        # the design plane at the top
    flat = Cutter("flat", d=4.0, r=0.0, R=2.0, flute_length=10.0)
    _cut(stock, flat, [[7.0, 11.0, 5.0], [7.0, 11.0, -0.3]])
    mesh = _plane(1, 1, 19, 19, 0.0, h)
    dev = signed_deviation(stock, mesh.vertices, mesh.normals, 10.0, 5.0)
    r = np.hypot(mesh.vertices[:, 0] - 7.0, mesh.vertices[:, 1] - 11.0)
    # the over-cut is the depth below the design: 0.3 on the hole's floor, the distance to
    # its wall near the rim (the column model places the wall within h / sqrt 2)
    inner, outer = r < 2.0 - 0.3 - h, r > 2.0 + h
    assert np.allclose(dev[inner], -0.3, atol=1e-5)
    assert np.allclose(dev[outer], 0.0, atol=1e-5)
    rim = (r < 2.0 - h) & ~inner
    assert np.allclose(dev[rim], -np.minimum(0.3, 2.0 - r[rim]), atol=h / math.sqrt(2) + 1e-5)
    deepest = mesh.vertices[dev < -0.3 + 1e-5]
    assert np.hypot(*(deepest[:, :2].mean(axis=0) - [7.0, 11.0])) < h


def _brute(stock, p, n, reach, step=1e-3):
    """The signed deviation by point membership sampled every `step` along the normal."""
    def inside(q):
        i = int(np.floor((q[0] - stock.x0) / stock.h))
        j = int(np.floor((q[1] - stock.y0) / stock.h))
        if not (0 <= i < stock.nx and 0 <= j < stock.ny):
            return False
        k = stock.count[j, i]
        return bool(np.any((stock.lo[j, i, :k] <= q[2]) & (q[2] <= stock.hi[j, i, :k])))
    t = np.arange(0.0, reach, step)
    if inside(p):
        ins = [inside(p + s * n) for s in t]
        return t[ins.index(False)] if False in ins else reach
    ins = [inside(p - s * n) for s in t]
    along = t[ins.index(True)] if True in ins else reach
    # the nearest material: the columns' boxes within `along`, by brute force
    x = stock.x0 + np.arange(stock.nx) * stock.h
    y = stock.y0 + np.arange(stock.ny) * stock.h
    gx = np.maximum.reduce([x - p[0], np.zeros_like(x), p[0] - (x + stock.h)])
    gy = np.maximum.reduce([y - p[1], np.zeros_like(y), p[1] - (y + stock.h)])
    best = along
    for j in range(stock.ny):
        for i in range(stock.nx):
            for k in range(stock.count[j, i]):
                gz = max(stock.lo[j, i, k] - p[2], 0.0, p[2] - stock.hi[j, i, k])
                best = min(best, math.sqrt(gx[i] ** 2 + gy[j] ** 2 + gz ** 2))
    return -best


def test_oblique_walk_and_nearest_material_agree_with_brute_force():
    rng = np.random.default_rng(3)
    h = 0.2
    stock = Dexels.box([0, 0, 0], [6, 6, 4], h)
    ball = Cutter("ball", d=3.0, r=1.5, R=0.0, flute_length=10.0)
    _cut(stock, ball, [[-1, 1.0, 2.5], [7, 4.0, 1.0], [3, 7, 0.5], [3, -1, 3.0]], step=0.1)
    p = rng.uniform([1, 1, 0.5], [5, 5, 3.5], (40, 3))
    n = rng.normal(size=(40, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    got = signed_deviation(stock, p, n, 3.0, 3.0)
    want = np.array([_brute(stock, p[k], n[k], 3.0) for k in range(40)])
    assert (want < 0).sum() > 5 and (want > 0).sum() > 5
    assert np.allclose(got, want, atol=2e-3)              # the brute force's step


def test_an_overcut_is_a_gouge_beyond_tolerance_and_bound_only():
    from checker.verdict import decide_machined, is_finding

    depth = np.array([-0.5, 0.0, 0.01, 0.05, 0.0701, 0.2])
    v = decide_machined(depth, 0.02, np.array([0.05, 0.05, 0.05, 0.05, 0.05, 0.3]))
    assert list(v) == ["ok", "ok", "within_tolerance", "within_tolerance", "gouge",
                       "within_tolerance"]
    assert list(is_finding(v)) == [False, False, False, False, True, False]
