"""The Z-dexel material removal (checker/stock, docs/MATH.md §14) against closed forms and
independent numpy oracles (profiles written here from the cutter's definition, not the
kernel's code), each within the model's stated bound (`error_bound`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from checker.cutter import Cutter
from checker.mesh.tool import tool_pieces
from checker.stock.dexels import Dexels
from checker.stock.removal import Removal, default_resolution, error_bound, remove

Z = (0.0, 0.0, 1.0)


def _cut(stock: Dexels, cutter: Cutter, path, *, axis=Z, step=0.05, holder=False,
         moves=None) -> Removal:
    """Cut along the polyline `path` (k, 3): one item and one move per segment."""
    p = np.asarray(path, np.float64)
    a, b = p[:-1], p[1:]
    ax = np.tile(np.asarray(axis, np.float64), (len(a), 1))
    mv = np.arange(len(a)) if moves is None else np.asarray(moves)
    return remove(stock, tool_pieces(cutter, with_holder=holder), a, b, ax, mv,
                  int(mv.max()) + 1, step=step)


def _grid(stock: Dexels):
    return np.meshgrid(stock.xs(), stock.ys())


# ---------------------------------------------------------------- constructors


def test_box_and_cylinder_constructors_hold_the_analytic_solids():
    box = Dexels.box([1.0, 2.0, -3.0], [11.0, 7.0, 4.0], 0.1)
    assert (box.nx, box.ny) == (100, 50)
    assert box.volume() == pytest.approx(10 * 5 * 7, rel=1e-9)
    assert np.allclose(box.top(), 4.0) and np.allclose(box.bottom(), -3.0)
    cyl = Dexels.cylinder("x", (0.0, 5.0), 20.0, 0.0, 30.0, 0.05)
    x, y = _grid(cyl)
    top = cyl.top()
    inside = np.abs(y) < 20.0
    assert np.allclose(top[inside], 5.0 + np.sqrt(400.0 - y[inside] ** 2), atol=1e-5)
    # the rays sample the disk: volume within the columns' bound (perimeter x h / sqrt 2)
    assert abs(cyl.volume() - math.pi * 400 * 30) <= 2 * 40 * 0.05 * 30 + 1e-6
    disk = Dexels.cylinder("z", (3.0, 4.0), 5.0, -1.0, 2.0, 0.02)
    assert abs(disk.volume() - math.pi * 25 * 3) <= 2 * math.pi * 5 * 0.02 / math.sqrt(2) * 3
    with pytest.raises(ValueError):
        Dexels.cylinder("w", (0, 0), 1.0, 0.0, 1.0, 0.1)


def test_default_resolution_and_error_bound():
    assert default_resolution([100, 100, 50]) == 0.05
    assert default_resolution([10, 10, 5]) == 0.01
    assert default_resolution([1000, 500, 50]) == 0.5
    along, lateral = error_bound(0.1, 0.2)
    assert along == pytest.approx(0.1) and lateral == pytest.approx(0.1 / math.sqrt(2))


# ---------------------------------------------------------------- vertical exact sweep


def test_facing_passes_leave_the_programmed_plane_and_remove_the_analytic_volume():
    stock = Dexels.box([0, 0, 0], [40, 30, 10], 0.1)
    flat = Cutter("flat", d=10.0, r=0.0, R=5.0, flute_length=25.0)
    ys = np.arange(-2.0, 33.0, 7.0)                   # overlapping passes, step-over 7 < 10
    path = []
    for k, y in enumerate(ys):                        # zig-zag at z = 6.5 with stepovers
        xa, xb = (-8.0, 48.0) if k % 2 == 0 else (48.0, -8.0)
        path += [[xa, y, 6.5], [xb, y, 6.5]]
    rem = _cut(stock, flat, path)
    assert np.nanmax(np.abs(stock.top() - 6.5)) <= 1e-4
    assert rem.volume[:, 0].sum() == pytest.approx(40 * 30 * 3.5, rel=1e-9)
    assert np.all(rem.volume[:, 1:] == 0.0)
    first = rem.thickness[0, 0]
    assert first == pytest.approx(3.5, abs=1e-5)
    # the first pass engages y in [0, 3] of its 10 mm: its width is 3 (within one ray)
    assert abs(rem.width[0] - 3.0) <= stock.h
    assert rem.rays[0] == 30 * 400 and rem.rays[2] == 70 * 400     # y in [0, 3], then (3, 10]


def test_ball_slot_cross_section_is_the_balls_circle():
    stock = Dexels.box([0, 0, 0], [30, 30, 10], 0.05)
    R = 3.0
    ball = Cutter("ball", d=2 * R, r=R, R=0.0, flute_length=20.0)
    a, b = np.array([-5.0, 2.0, 7.5]), np.array([35.0, 28.0, 7.5])      # diagonal slot
    rem = _cut(stock, ball, [a, b])
    x, y = _grid(stock)
    u = (b - a)[:2] / np.linalg.norm((b - a)[:2])
    across = np.abs((x - a[0]) * u[1] - (y - a[1]) * u[0])
    expect = np.minimum(10.0, 7.5 + R - np.sqrt(np.maximum(R * R - across ** 2, 0.0)))
    expect = np.where(across < R, expect, 10.0)
    assert np.max(np.abs(stock.top() - expect)) <= 1e-5
    assert rem.thickness[0, 0] == pytest.approx(R - 0.5, abs=1e-4)
    assert abs(rem.width[0] - 2 * math.sqrt(R * R - 0.25)) <= 2 * stock.h


def _bull_low(d, R, r):
    """The lowest height of a bull-nose (corner-centre radius R, corner radius r) at radial
    distance d from its axis: 0 on the flat, the torus beyond (inf outside)."""
    e = np.maximum(d - R, 0.0)
    return np.where(d <= R + r, r - np.sqrt(np.maximum(r * r - e * e, 0.0)), np.inf)


@pytest.mark.parametrize("kind, up", [("bullnose", False), ("bullnose", True),
                                      ("ball", False)])
def test_ramped_move_equals_brute_force_over_poses(kind, up):
    stock = Dexels.box([0, 0, 0], [30, 20, 10], 0.1)
    R, r = (3.0, 1.5) if kind == "bullnose" else (0.0, 3.0)
    cutter = Cutter(kind, d=2 * (R + r), r=r, R=R, flute_length=30.0)
    a, b = np.array([2.0, 8.0, 9.0]), np.array([27.0, 12.0, 5.5])
    if up:
        a, b = b, a
    _cut(stock, cutter, [a, b])
    x, y = _grid(stock)
    band = np.zeros(x.shape, bool)
    band[::2, ::2] = np.abs(y[::2, ::2] - 10.0) < 7.0
    px, py = x[band], y[band]
    best = np.full(px.shape, np.inf)
    for t in np.array_split(np.linspace(0.0, 1.0, 20_000), 20):
        tip = a[None, :] + t[:, None] * (b - a)[None, :]
        d = np.hypot(px[:, None] - tip[None, :, 0], py[:, None] - tip[None, :, 1])
        best = np.minimum(best, (tip[None, :, 2] + _bull_low(d, R, r)).min(axis=1))
    brute = np.minimum(best, 10.0)
    got = stock.top()[band]
    # exact per ray: never above the sampled minimum, and below it only by what 20,000 poses
    # miss (1.3e-3 mm of travel each)
    assert np.all(got <= brute + 1e-5)
    assert np.all(got >= brute - 3e-3)
    assert np.median(brute - got) <= 1e-4


def test_pocket_removes_the_analytic_volume():
    h = 0.1
    stock = Dexels.box([0, 0, 0], [50, 30, 10], h)
    Rt = 3.0
    flat = Cutter("flat", d=2 * Rt, r=0.0, R=Rt, flute_length=20.0)
    x0, x1, y0, y1 = 10.0, 40.0, 5.0, 25.0          # pocket, corner radius = the tool's
    cx0, cx1, cy0, cy1 = x0 + Rt, x1 - Rt, y0 + Rt, y1 - Rt
    path = [[cx0, cy0, 15.0]]
    for z in (8.0, 6.0):                              # two levels, plunge then zig-zag
        path.append([cx0, cy0, z])
        for k, y in enumerate(np.linspace(cy0, cy1, 5)):
            xa, xb = (cx0, cx1) if k % 2 == 0 else (cx1, cx0)
            path += [[xa, y, z], [xb, y, z]]
        path += [[cx1, cy0, z], [cx0, cy0, z], [cx0, cy1, z], [cx1, cy1, z], [cx1, cy0, z]]
    rem = _cut(stock, flat, path)
    area = (x1 - x0) * (y1 - y0) - (4.0 - math.pi) * Rt * Rt
    perimeter = 2 * (x1 - x0 + y1 - y0) - (8.0 - 2 * math.pi) * Rt
    exact = area * 4.0
    assert abs(rem.volume.sum() - exact) <= perimeter * h / math.sqrt(2) * 4.0
    assert abs(rem.volume.sum() - exact) <= 0.01 * exact
    x, y = _grid(stock)
    deep = (x > x0 + h) & (x < x1 - h) & (y > y0 + Rt) & (y < y1 - Rt)
    assert np.max(np.abs(stock.top()[deep] - 6.0)) <= 1e-4
    outside = (x < x0 - h) | (x > x1 + h) | (y < y0 - h) | (y > y1 + h)
    assert np.all(stock.top()[outside] == 10.0)
    assert stock.volume() == pytest.approx(50 * 30 * 10 - rem.volume.sum(), rel=1e-6)


# ---------------------------------------------------------------- shank, holder, overflow


def test_plunge_past_the_flutes_charges_the_shank_and_the_holder():
    stock = Dexels.box([-20, -20, -60], [20, 20, 0], 0.1)
    c = Cutter("flat", d=6.0, r=0.0, R=3.0, flute_length=10.0, shank_diameter=6.0,
               stickout=30.0, holder_diameter=24.0, holder_length=40.0)
    rem = _cut(stock, c, [[-10, -10, 5.0], [-10, -10, -15.0], [-10, -10, 5.0], [7, 7, 5.0],
                          [7, 7, -35.0]], holder=True)
    # move 0: 15 mm deep, flute length 10: the shank goes 5 mm below the surface
    assert rem.thickness[0, 0] == pytest.approx(10.0, abs=1e-4)
    assert rem.thickness[0, 1] == pytest.approx(5.0, abs=1e-4)
    assert rem.thickness[0, 2] == 0.0
    assert rem.where[0, 1, 2] == pytest.approx(-2.5, abs=1e-4)
    assert np.hypot(*(rem.where[0, 1, :2] + 10.0)) <= 3.0
    # move 1 retracts through the empty hole, move 2 travels above the stock
    assert np.all(rem.volume[1:3] == 0.0)
    # move 3: 35 mm deep, stickout 30: the holder (radius 12) 5 mm into the stock
    assert rem.thickness[3, 2] == pytest.approx(5.0, abs=1e-4)
    assert rem.thickness[3, 1] == pytest.approx(20.0, abs=1e-4)
    # the holder (charged first) removes its whole disk 5 mm deep
    assert abs(rem.volume[3, 2] - math.pi * 144 * 5) <= 2 * math.pi * 12 * 0.1 * 5
    assert abs(rem.volume[3, 1] - math.pi * 9 * 20) <= 2 * math.pi * 3 * 0.1 * 20
    assert abs(rem.width[3] - 6.0) <= 0.2


def test_rapid_through_material_reports_its_depth_along_the_rays():
    stock = Dexels.box([0, 0, 0], [40, 20, 10], 0.1)
    flat = Cutter("flat", d=8.0, r=0.0, R=4.0, flute_length=20.0)
    rem = _cut(stock, flat, [[-10, 10, 8.75], [50, 10, 8.75]])
    assert rem.thickness[0, 0] == pytest.approx(1.25, abs=1e-5)
    assert rem.volume[0, 0] == pytest.approx(40 * 8 * 1.25, rel=0.02)
    assert abs(rem.where[0, 0, 2] - 9.375) <= 1e-5
    assert abs(rem.width[0] - 8.0) <= 2 * stock.h


def _side_drill(capacity: int):
    stock = Dexels.box([0, 0, 0], [20, 20, 20], 0.1, capacity=capacity)
    drill = Cutter("flat", d=6.0, r=0.0, R=3.0, flute_length=40.0)
    rem = _cut(stock, drill, [[-5, 10, 10], [12, 10, 10]], axis=(-1.0, 0.0, 0.0), step=0.05)
    return stock, rem


def test_a_tunnel_splits_rays_and_overflows_a_full_ray():
    stock, rem = _side_drill(2)
    tunnel = math.pi * 9 * 12                          # x from 0 to the tip at 12
    assert abs(rem.volume[0, 0] - tunnel) <= 2 * math.pi * 3 * 0.1 * 12
    assert stock.overflow == 0 and int(stock.count.max()) == 2
    full, rem1 = _side_drill(1)
    assert full.overflow > 0 and rem1.refused == full.overflow
    assert full.volume() == pytest.approx(20 ** 3, rel=1e-9)   # material kept, never lost
    assert int(full.count.max()) == 1


# ---------------------------------------------------------------- sampled general axis


def test_four_axis_turning_leaves_the_analytic_radius():
    h = 0.1
    rho, Rs = 15.0, 20.0
    stock = Dexels.cylinder("x", (0.0, 0.0), Rs, 0.0, 10.0, h)
    flat = Cutter("flat", d=20.0, r=0.0, R=10.0, flute_length=12.0)
    dphi = math.radians(2.0)
    phi = np.arange(0.0, 2 * math.pi, dphi)
    axis = np.stack([np.zeros_like(phi), np.sin(phi), np.cos(phi)], axis=1)
    tips = rho * axis + np.array([5.0, 0.0, 0.0])
    step = rho * dphi                                  # a pose chain: the tip travels step
    rem = remove(stock, tool_pieces(flat, with_holder=False), tips, tips, axis,
                 np.zeros(len(phi), np.int64), 1, step=step)
    x, y = _grid(stock)
    ok = np.abs(y) < 0.9 * rho
    expect = np.sqrt(rho * rho - y[ok] ** 2)
    # between two poses dphi apart the flat bottoms leave at most rho (sec(dphi / 2) - 1)
    # radially; along a ray that is divided by the surface's cosine rho_z / rho
    scallop = rho * (1.0 / math.cos(dphi / 2) - 1.0)
    slack = scallop * rho / expect + 1e-4
    assert np.all(stock.top()[ok] >= expect - 1e-4)
    assert np.all(stock.top()[ok] <= expect + slack)
    assert np.all(stock.bottom()[ok] <= -expect + 1e-4)
    assert np.all(stock.bottom()[ok] >= -expect - slack)
    assert np.all(stock.count[np.abs(y) > rho + h] == 0)
    assert error_bound(h, step)[0] >= np.max(slack)
    assert rem.volume[0, 0] == pytest.approx(math.pi * (Rs ** 2 - rho ** 2) * 10, rel=0.01)


def _membership(px, pz, tip, u, Rf, hb, ht, rho):
    """Inside the solid of revolution {(r, h): dist((r, h), [0, Rf] x [hb, ht]) <= rho} at tip,
    unit axis u (a flat end mill: rho = 0; a ball: Rf = 0; a bull-nose): (n, m) for points
    (px (n, 2), pz (m,))."""
    w = np.concatenate([np.broadcast_to(px[:, None, :], (len(px), len(pz), 2)),
                        np.broadcast_to(pz[None, :, None], (len(px), len(pz), 1))],
                       axis=2) - tip
    hh = w @ u
    rr = np.linalg.norm(w - hh[..., None] * u, axis=2)
    dr = np.maximum(rr - Rf, 0.0)
    dh = np.maximum(np.maximum(hb - hh, hh - ht), 0.0)
    return dr * dr + dh * dh <= rho * rho + 1e-12


@pytest.mark.parametrize("kind", ["flat", "ball", "bullnose"])
def test_tilted_constant_axis_within_half_a_step_of_point_membership(kind):
    h, step = 0.25, 0.4
    stock = Dexels.box([0, 2, 0], [20, 10, 10], h)
    L = 30.0
    R, r = {"flat": (3.0, 0.0), "ball": (0.0, 3.0), "bullnose": (2.0, 1.0)}[kind]
    cutter = Cutter(kind, d=2 * (R + r), r=r, R=R, flute_length=L)
    tilt = math.radians(30.0)
    u = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    a, b = np.array([3.0, 6.0, 8.0]), np.array([15.0, 6.0, 7.0])
    rem = remove(stock, tool_pieces(cutter, with_holder=False), a[None], b[None], u[None],
                 np.zeros(1, np.int64), 1, step=step)
    n_k = int(math.ceil(np.linalg.norm(b - a) / step)) + 1
    x, y = _grid(stock)
    px = np.stack([x.ravel(), y.ravel()], axis=1)
    dz = 0.02
    pz = np.arange(5.0, 10.0, dz) + dz / 2           # the tool reaches down to 5.5
    hit = np.zeros((len(px), len(pz)), bool)
    for t in np.linspace(0.0, 1.0, 2 * (n_k - 1) + 1):        # 2x finer, same poses too
        hit |= _membership(px, pz, a + t * (b - a), u, R, r, L, r)
    # the kernel's removed samples: not inside any of its ray's intervals
    slot = np.arange(stock.capacity)[None, None, :] < stock.count[:, :, None]
    lo = np.where(slot, stock.lo, np.inf).reshape(len(px), -1)
    hi = np.where(slot, stock.hi, -np.inf).reshape(len(px), -1)
    kept = ((lo[:, None, :] <= pz[None, :, None]) & (pz[None, :, None] <= hi[:, None, :]))
    cut = ~kept.any(axis=2)
    # the kernel's poses are among the oracle's: it removes nothing the oracle keeps (one
    # sample's slack at the ends of each removed stretch)
    near = hit.copy()
    near[:, 1:] |= hit[:, :-1]
    near[:, :-1] |= hit[:, 1:]
    assert not np.any(cut & ~near)
    # where the oracle's floor is not a wall, the kernel's floor is within half a step of it
    # along the travel, which moves the tilted floor by at most step/2 (1 + tan 30 deg)
    low = np.where(hit.any(axis=1), pz[np.argmax(hit, axis=1)], 10.0).reshape(x.shape)
    lowk = np.where(cut.any(axis=1), pz[np.argmax(cut, axis=1)], 10.0).reshape(x.shape)
    gy, gx = np.gradient(low, h)
    floor = (np.hypot(gx, gy) < 1.0) & (low < 10.0)
    floor[1:-1, 1:-1] &= (low[:-2, 1:-1] < 10) & (low[2:, 1:-1] < 10)
    assert floor.sum() > 100
    bound = 0.5 * step * (1.0 + math.tan(tilt)) + dz
    assert np.max(lowk[floor] - low[floor]) <= bound
    vol_oracle = hit.sum() * dz * h * h
    assert rem.volume[0, 0] <= vol_oracle + 2 * dz * h * h * len(px)
    assert rem.volume[0, 0] >= 0.95 * vol_oracle


def test_items_cut_in_chunks_give_the_same_stock_and_statistics(monkeypatch):
    import checker.stock.removal as removal
    ball = Cutter("ball", d=4.0, r=2.0, R=0.0, flute_length=20.0)
    path = [[-3, 2, 9.0], [20, 2, 8.0], [20, 5, 8.5], [-3, 5, 7.0], [-3, 8, 7.0], [20, 8, 9.5]]
    moves = [0, 0, 1, 1, 2]                            # moves of several items
    one = Dexels.box([0, 0, 0], [17, 10, 10], 0.1)
    r1 = _cut(one, ball, path, moves=moves)
    monkeypatch.setattr(removal, "CHUNK", 2)
    two = Dexels.box([0, 0, 0], [17, 10, 10], 0.1)
    r2 = _cut(two, ball, path, moves=moves)
    assert np.array_equal(one.top(), two.top(), equal_nan=True)
    assert np.allclose(r1.volume, r2.volume, rtol=1e-12)
    assert np.array_equal(r1.thickness, r2.thickness)
    assert np.array_equal(r1.where, r2.where, equal_nan=True)
    assert np.array_equal(r1.width, r2.width) and np.array_equal(r1.rays, r2.rays)
    assert r1.volume.sum() == pytest.approx(17 * 10 * 10 - one.volume())
