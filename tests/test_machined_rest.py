"""Rest machining on a sample (docs/MATH.md §15.4): a channel 20 mm wide and 10 deep with
fillets of radius 3 between its floor and walls, cut with a ball R 5 following the profile's
offset, leaves the fillets (0.83 mm at their middle: the ball touching floor and wall stands
2 sqrt 2 from the fillet's centre, its surface 5 - 2 sqrt 2 = 2.17 from it against the fillet's
3); the advice names a ball of the library that fits them, and the same strategy with that ball
over the fillets leaves nothing beyond the threshold and cuts nothing below the design."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from checker.cutter import Cutter
from checker.machined.compare import Comparison
from checker.mesh.bvh import MeshIndex
from checker.mesh.tool import tool_pieces
from checker.stock.dexels import Dexels
from checker.stock.removal import remove
from checker.tool_library import load_tool_library

H = 0.05
FILLET = 3.0
LENGTH = 30.0
TOL = 0.02


def _profile(step: float) -> tuple[np.ndarray, np.ndarray]:
    """(y, z) points of the channel's profile from y = -15 to 15 at about `step` mm, and
    whether each is on a fillet."""
    def line(a, b):
        n = max(2, int(math.ceil(np.hypot(*np.subtract(b, a)) / step)) + 1)
        return np.linspace(a, b, n)[:-1]

    def arc(c, a0, a1):
        n = max(2, int(math.ceil(FILLET * abs(a1 - a0) / step)) + 1)
        t = np.linspace(a0, a1, n)[:-1]
        return np.column_stack([c[0] + FILLET * np.cos(t), c[1] + FILLET * np.sin(t)])

    parts = [(line((-15, 0), (-10, 0)), False), (line((-10, 0), (-10, -7)), False),
             (arc((-7, -7), math.pi, 1.5 * math.pi), True), (line((-7, -10), (7, -10)), False),
             (arc((7, -7), 1.5 * math.pi, 2 * math.pi), True), (line((10, -7), (10, 0)), False),
             (np.array([[10.0, 0.0], [15.0, 0.0]]), False)]
    pts = np.concatenate([p for p, _ in parts])
    fillet = np.concatenate([np.full(len(p), f) for p, f in parts])
    return pts, fillet


def _part():
    """The channel extruded along x over [0, LENGTH]: triangles, normals toward the air."""
    yz, _ = _profile(0.25)
    xs = np.linspace(0.0, LENGTH, 31)
    V = np.array([[x, y, z] for x in xs for y, z in yz])
    k = len(yz)
    T = []
    for i in range(len(xs) - 1):
        for j in range(k - 1):
            a, b, c, d = i * k + j, i * k + j + 1, (i + 1) * k + j + 1, (i + 1) * k + j
            T += [[a, d, c], [a, c, b]]
    T = np.array(T)
    n = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    t2 = yz[1:] - yz[:-1]                                  # the profile's left normal: the air
    left = np.column_stack([-t2[:, 1], t2[:, 0]])
    want = np.tile(np.repeat(left, 2, axis=0), (len(xs) - 1, 1))
    flip = np.einsum("ij,ij->i", n[:, 1:], want) < 0
    T[flip] = T[flip][:, [0, 2, 1]]
    return SimpleNamespace(vertices=V, triangles=T, surface=np.full(len(T), -1))


def _follow(r: float, step: float, corners: bool = False) -> np.ndarray:
    """Ball centres (y, z) following the profile's offset by r, every `step` mm of profile:
    each profile point's offset along its normal, kept where the ball does not cut the
    profile (a ball larger than the fillet stops where it touches floor and wall); `corners`:
    only over the profile's corners (|y| > 5, z < -5: the fillets and the floor and wall the
    ball R 5 stands off)."""
    yz, _ = _profile(0.01)
    t = np.gradient(yz, axis=0)
    n = np.column_stack([-t[:, 1], t[:, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    c = yz + r * n
    d = np.min(np.linalg.norm(c[:, None, :] - yz[None, ::5, :], axis=2), axis=1)
    keep = d >= r - 1e-3
    if corners:
        keep &= (np.abs(yz[:, 0]) > 5.0) & (yz[:, 1] < -5.0)
    ends = np.flatnonzero(np.diff(keep.astype(int)) != 0)       # the runs' ends: the corners
    ends = np.unique(np.r_[ends, ends + 1])
    corners = c[ends[keep[ends]]]
    c = c[keep]
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))]
    pick = np.unique(np.searchsorted(s, np.arange(0.0, s[-1] + 1e-9, step)).clip(0, len(c) - 1))
    return np.concatenate([c[pick], corners])


def _cut(stock: Dexels, r: float, centres: np.ndarray) -> None:
    ball = Cutter("ball", d=2 * r, r=r, R=0.0, flute_length=30.0)
    a = np.column_stack([np.full(len(centres), -r - 1), centres[:, 0], centres[:, 1] - r])
    b = a.copy()
    b[:, 0] = LENGTH + r + 1
    keep = centres[:, 1] - r < 0.5                          # passes in the stock
    remove(stock, tool_pieces(ball, with_holder=False), a[keep], b[keep],
           np.tile([0.0, 0.0, 1.0], (keep.sum(), 1)), np.arange(keep.sum()), int(keep.sum()),
           step=H)


def test_a_ball_too_large_for_the_fillets_leaves_them_and_the_advised_ball_finishes_them():
    part = _part()
    index = MeshIndex.build(part.vertices, part.triangles)
    stock = Dexels.box([0.0, -15.0, -12.0], [LENGTH, 15.0, 0.0], H)
    big = Cutter("ball", d=10.0, r=5.0, R=0.0, flute_length=30.0)
    library = load_tool_library()
    cmp = Comparison(part, index, stock, {0: big, 1: big}, np.full(2, TOL), np.zeros(2),
                     0.5 * H)
    _cut(stock, 5.0, _follow(5.0, 0.25))
    cmp.after(0, stock)
    got = cmp.result(library)
    assert got.gouge_points == 0 and got.overcut_max <= 0.5 * H + H / math.sqrt(2)
    # the two fillets, the whole length, 0.83 mm thick at their middle
    assert len(got.left) == 2
    middle = 3.0 - (5.0 - 2.0 * math.sqrt(2.0))
    for region in got.left:
        y, z = region.point[1], region.point[2]
        assert abs(abs(y) - 7.0 - FILLET / math.sqrt(2)) < 0.3 and abs(z + 9.12) < 0.3
        assert region.max == pytest.approx(middle, abs=got.bound_max)
        # the fillet's arc, and the floor and the wall where the ball (touching them 2 mm
        # from the fillet) stands more than the threshold off them: 5 - sqrt(25 - e^2) > thr
        floor = 2.0 - math.sqrt(25.0 - (5.0 - TOL - 0.5 * H) ** 2)
        wall = 2.0 - math.sqrt(25.0 - (5.0 - TOL - 0.5 * H - H / math.sqrt(2)) ** 2)
        width = 0.5 * math.pi * FILLET + floor + wall
        assert region.area == pytest.approx(LENGTH * width, rel=0.05)
        assert region.op == 0
    assert got.operations[0].left_max == pytest.approx(middle, abs=got.bound_max)
    # the advice: a ball no larger than the fillet (its allowable r at the fillet's points)
    sizes = [r.allowable for r in got.left]
    assert all(2.5 <= s <= FILLET + 0.05 for s in sizes)
    tool = library[got.left[0].tool]
    assert tool.kind == "ball" and tool.r <= min(sizes) and tool.r >= 2.5
    assert got.advice.startswith("rest machining: 2 regions,")
    assert got.advice.endswith(f"largest safe tool {tool.name}")
    # the same strategy with that ball over the regions: nothing left beyond the threshold
    _cut(stock, tool.r, _follow(tool.r, 0.2, corners=True))
    cmp.after(1, stock)
    done = cmp.result(library)
    assert done.left == [] and done.left_points == 0 and done.gouge_points == 0
    assert done.operations[1].points_cut > 100
