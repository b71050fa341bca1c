"""The tool frame of a pose: tip at the origin, axis +z, and two unit vectors across the axis,
chosen from the axis alone; points and triangles of the part frame into it and back (mm).
(docs/MATH.md §1)"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np


class ToolFrame(NamedTuple):
    """A pose's tool frame in the part frame (mm): its origin `tip`, unit axes `e1`, `e2`
    (across the tool) and `axis` (tip -> spindle), each an (x, y, z) tuple."""

    tip: tuple[float, float, float]
    e1: tuple[float, float, float]
    e2: tuple[float, float, float]
    axis: tuple[float, float, float]


@nb.njit(cache=True)
def tool_frame(tip, axis):
    """The `ToolFrame` at `tip` with the direction `axis` (3-tuples, part frame; normalised
    here): e1 the part frame's x axis (its y axis when the tool is near x) made normal to the
    axis, e2 = axis x e1."""
    ax, ay, az = axis
    n = math.sqrt(ax * ax + ay * ay + az * az)
    ax, ay, az = ax / n, ay / n, az / n
    if abs(ax) < 0.9:
        rx, ry, rz = 1.0, 0.0, 0.0
    else:
        rx, ry, rz = 0.0, 1.0, 0.0
    d = rx * ax + ry * ay + rz * az
    e1x, e1y, e1z = rx - d * ax, ry - d * ay, rz - d * az
    n1 = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    e1x, e1y, e1z = e1x / n1, e1y / n1, e1z / n1
    e2x = ay * e1z - az * e1y
    e2y = az * e1x - ax * e1z
    e2z = ax * e1y - ay * e1x
    return ToolFrame(tip, (e1x, e1y, e1z), (e2x, e2y, e2z), (ax, ay, az))


@nb.njit(cache=True, _nrt=False)
def direction_in_tool(f, d):
    """The direction `d` (part frame) in the tool frame `f`."""
    e1, e2, e = f.e1, f.e2, f.axis
    return (d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2],
            d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2],
            d[0] * e[0] + d[1] * e[1] + d[2] * e[2])


@nb.njit(cache=True, _nrt=False)
def triangle_in_tool(f, verts, t, T):
    """Triangle t's vertices `verts[t] (3, 3)` (part frame) into rows 0-2 of T, tool frame."""
    px, py, pz = f.tip
    e1, e2, e = f.e1, f.e2, f.axis
    for v in range(3):
        dx, dy, dz = verts[t, v, 0] - px, verts[t, v, 1] - py, verts[t, v, 2] - pz
        T[v, 0] = dx * e1[0] + dy * e1[1] + dz * e1[2]
        T[v, 1] = dx * e2[0] + dy * e2[1] + dz * e2[2]
        T[v, 2] = dx * e[0] + dy * e[1] + dz * e[2]


@nb.njit(cache=True)
def point_in_part(f, x, y, z):
    """The point (x, y, z) of the tool frame `f` in the part frame."""
    e1, e2, e = f.e1, f.e2, f.axis
    return (f.tip[0] + x * e1[0] + y * e2[0] + z * e[0],
            f.tip[1] + x * e1[1] + y * e2[1] + z * e[1],
            f.tip[2] + x * e1[2] + y * e2[2] + z * e[2])


@nb.njit(cache=True)
def along_axis(f, h):
    """The point of the tool's axis at height h above the tip (part frame)."""
    e = f.axis
    return (f.tip[0] + h * e[0], f.tip[1] + h * e[1], f.tip[2] + h * e[2])


@nb.njit(cache=True)
def box_top(lo, hi, f):
    """The height above the tip, along the axis, of the highest corner of the box `lo, hi
    (3,)` (part frame)."""
    px, py, pz = f.tip
    ex, ey, ez = f.axis
    hm = -np.inf
    for c in range(8):
        qx = hi[0] if c & 1 else lo[0]
        qy = hi[1] if c & 2 else lo[1]
        qz = hi[2] if c & 4 else lo[2]
        hm = max(hm, (qx - px) * ex + (qy - py) * ey + (qz - pz) * ez)
    return hm
