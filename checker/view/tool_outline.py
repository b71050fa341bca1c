"""The real tool's pieces (`checker.mesh.tool.tool_pieces`: body, shank, holder) as the half
outlines a lathe revolves: each piece's convex profile grown by its ball radius rho (the
Minkowski sum of the polygon and a disc), cut to r >= 0, from the axis at the bottom round the
outside to the axis at the top. Tool frame: tip at the origin, axis +z; (r, h) in mm."""

from __future__ import annotations

import math

import numpy as np

from checker.mesh.tool import UNBOUNDED, tool_pieces

PIECE_NAMES = ("body", "shank", "holder")
ARC_STEPS = 12  # segments of a quarter turn of a grown corner


def _grown(poly: np.ndarray, rho: float) -> np.ndarray:
    """The closed outline of the convex counter-clockwise polygon `poly (n, 2)` grown by `rho`:
    its vertices, each corner rounded by an arc of radius rho."""
    n = len(poly)
    if rho <= 0.0 or n == 0:
        return poly.copy()
    if n == 1:
        a = np.linspace(-math.pi, math.pi, 4 * ARC_STEPS, endpoint=False)
        return poly[0] + rho * np.column_stack([np.cos(a), np.sin(a)])
    out = []
    for i in range(n):
        prev, here, nxt = poly[i - 1], poly[i], poly[(i + 1) % n]
        d0, d1 = here - prev, nxt - here
        a0 = math.atan2(-d0[0], d0[1])  # outward normal (dy, -dx) of the edge into the vertex
        a1 = math.atan2(-d1[0], d1[1])
        sweep = (a1 - a0) % (2.0 * math.pi)
        k = max(1, int(math.ceil(sweep / (0.5 * math.pi) * ARC_STEPS)))
        a = a0 + sweep * np.arange(k + 1) / k
        out.append(here + rho * np.column_stack([np.cos(a), np.sin(a)]))
    return np.concatenate(out)


def _clip(poly: np.ndarray, axis: int, limit: float, keep_above: bool) -> np.ndarray:
    """Sutherland-Hodgman: the part of the closed polygon on one side of coordinate `axis` =
    `limit`."""
    s = (poly[:, axis] - limit) * (1.0 if keep_above else -1.0)
    out = []
    n = len(poly)
    for i in range(n):
        j = (i + 1) % n
        if s[i] >= 0.0:
            out.append(poly[i])
        if (s[i] >= 0.0) != (s[j] >= 0.0):
            f = s[i] / (s[i] - s[j])
            out.append(poly[i] + f * (poly[j] - poly[i]))
    return np.array(out).reshape(-1, 2)


def _lathe(poly: np.ndarray) -> np.ndarray:
    """The outline from its lowest point on the axis, counter-clockwise round the outside, to its
    highest point on the axis."""
    on_axis = np.flatnonzero(poly[:, 0] <= 1e-9)
    start = on_axis[np.argmin(poly[on_axis, 1])]
    ring = np.roll(poly, -start, axis=0)
    on_axis = np.flatnonzero(ring[:, 0] <= 1e-9)
    end = on_axis[np.argmax(ring[on_axis, 1])]
    line = ring[: end + 1].copy()
    line[:, 0] = np.maximum(line[:, 0], 0.0)
    keep = np.r_[True, np.any(np.abs(np.diff(line, axis=0)) > 1e-9, axis=1)]
    return line[keep]


def tool_outlines(cutter) -> list[dict]:
    """The pieces of `cutter` (a `checker.cutter.Cutter`, holder included when known) as
    `{"piece": "body"|"shank"|"holder", "outline": [[r, h], ...]}`; a body of unknown length is
    drawn up to the stick-out, else four diameters."""
    pieces = tool_pieces(cutter, with_holder=True)
    cap = float(cutter.stickout) if cutter.stickout else 4.0 * float(cutter.d)
    out = []
    for p in range(len(pieces)):
        poly = pieces.prof[p, : pieces.nprof[p]]
        grown = _grown(poly, float(pieces.rho[p]))
        grown = _clip(grown, 0, 0.0, keep_above=True)
        if poly[:, 1].max() >= 0.5 * UNBOUNDED:
            grown = _clip(grown, 1, max(cap, float(pieces.rho[p]) * 2.0), keep_above=False)
        out.append({"piece": PIECE_NAMES[int(pieces.kind[p])],
                    "outline": np.round(_lathe(grown), 4).tolist()})
    return out
