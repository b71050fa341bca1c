"""Mesh parts for the 5-axis feasibility tests and benchmark (tests/test_five_axis_feasible.py,
benchmarks/bench_feasible.py): a concave half-pipe (the closed form) and a free-form channel
(two walls and a floor). mm, part frame; triangle normals out of the material."""

from __future__ import annotations

import dataclasses

import numpy as np

from checker.cutter import parse_cutter
from checker.part import MeshPart, Part


def _sheet(points: np.ndarray) -> Part:
    """A mesh part from a (U, V, 3) grid of points, each cell two triangles whose normal is
    (d/du x d/dv) (the caller orders u and v so that it points out of the material)."""
    nu, nv, _ = points.shape
    idx = np.arange(nu * nv).reshape(nu, nv)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    tri = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                          np.stack([a, c, d], -1).reshape(-1, 3)])
    v = points.reshape(-1, 3)
    n = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
    return Part([], mesh=MeshPart(v, tri, n / np.linalg.norm(n, axis=1)[:, None]))


def half_pipe(radius: float, length: float, segments: int) -> Part:
    """The inside of a cylinder of `radius` about the line y = 0, z = radius (along x, from
    -length/2 to length/2), its lower half: the cross-section the circle's arc from y = -radius
    to y = radius through the bottom (0, 0), as `segments` chords (vertices on the circle,
    one at the bottom when `segments` is even); the material outside the circle."""
    th = np.linspace(-np.pi / 2, np.pi / 2, segments + 1)
    x = np.linspace(-length / 2, length / 2, max(2, int(length // 10) + 1))
    X, TH = np.meshgrid(x, th, indexing="ij")
    return _sheet(np.stack([X, radius * np.sin(TH), radius * (1.0 - np.cos(TH))], -1))


def channel_floor(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Height (mm) of the channel's floor: a wave along x, concave across (radius 30 mm)."""
    return 3.0 * np.sin(x / 25.0) + y * y / 60.0


def channel_floor_normal(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, 3) unit normals of the floor (up, out of the material)."""
    n = np.column_stack([-3.0 / 25.0 * np.cos(x / 25.0), -y / 30.0, np.ones_like(x)])
    return n / np.linalg.norm(n, axis=1)[:, None]


def channel_half_width(x: np.ndarray) -> np.ndarray:
    """Half the channel's width (mm) at x: its walls stand at y = +-this."""
    return 14.0 + 2.0 * np.sin(x / 18.0)


def channel(spacing: float = 0.5, wall: float = 12.0) -> Part:
    """A free-form channel along x in [-40, 40]: the floor `channel_floor` between two vertical
    walls at y = +-`channel_half_width`, `wall` mm high above the floor's edge; the floor's
    grid has (x, y) vertices at multiples of `spacing` across (scaled to the width)."""
    x = np.linspace(-40.0, 40.0, int(round(80.0 / spacing)) + 1)
    nf = int(round(32.0 / spacing)) + 1
    nw = int(round(wall / spacing)) + 1
    w = channel_half_width(x)[:, None]
    t = np.linspace(-1.0, 1.0, nf)[None, :]
    fy = t * w
    fz = channel_floor(x[:, None], fy)
    s = np.linspace(1.0, 0.0, nw)[None, :]                # down the left wall, up the right
    left = np.stack([np.broadcast_to(x[:, None], (len(x), nw)), -w + 0 * s,
                     channel_floor(x[:, None], -w) + wall * s], -1)
    floor = np.stack([np.broadcast_to(x[:, None], fy.shape), fy, fz], -1)
    right = np.stack([np.broadcast_to(x[:, None], (len(x), nw)), w + 0 * s,
                      channel_floor(x[:, None], w) + wall * s[:, ::-1]], -1)
    pts = np.concatenate([left[:, :-1], floor, right[:, 1:]], axis=1)
    return _sheet(pts)


def channel_contacts(count: int, seed: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`count` CC points on the channel's floor (at vertices of `channel()`'s default grid),
    their normals and feed directions (+x), spread over the floor up to 4 mm from the walls."""
    rng = np.random.default_rng(seed)
    x = np.round(rng.uniform(-25.0, 25.0, count) / 0.5) * 0.5
    w = channel_half_width(x)
    nf = int(round(32.0 / 0.5))
    k = np.round((rng.uniform(-1.0, 1.0, count) * (w - 4.0) / w + 1.0) * nf / 2.0)
    y = (k / nf * 2.0 - 1.0) * w
    cc = np.column_stack([x, y, channel_floor(x, y)])
    return cc, channel_floor_normal(x, y), np.tile([1.0, 0.0, 0.0], (count, 1))


def tool(text: str, flute: float, shank: float, stickout: float, holder: float,
         holder_length: float):
    """The cutter `text` (APT CUTTER) with its flute length, shank diameter, stick-out and
    holder (diameter, length), mm."""
    return dataclasses.replace(parse_cutter(text), flute_length=flute, shank_diameter=shank,
                               stickout=stickout, holder_diameter=holder,
                               holder_length=holder_length)
