"""The local frame at a CC point and the (lead, tilt) angles of a tool axis in it
(docs/MATH.md §10.1). Part frame, radians.

Frame: `n` the unit surface normal (out of the material), `f` the feed direction projected into
the tangent plane and normalised, `s = n x f` (to the left of the feed seen from above the
surface). Angles: a tool axis `a` (tip -> spindle) has components

    (a.f, a.s, a.n) = (cos(tilt) sin(lead), sin(tilt), cos(tilt) cos(lead)),

i.e. `lead` turns the axis from `n` towards the feed direction about `s` (positive lead lifts the
heel of a flat bottom: the cutter's trailing edge), then `tilt` leans it sideways towards `s`.
`lead = tilt = 0` is the normal. The map is one to one for |lead| < pi/2, |tilt| < pi/2."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

_EPS = 1e-9  # a feed direction this close to the normal has no tangent part


class Frames(NamedTuple):
    """Per CC point (N, 3) unit vectors, part frame: feed `f`, normal `n`, side `s = n x f`."""

    f: np.ndarray
    n: np.ndarray
    s: np.ndarray


def local_frames(normals: np.ndarray, feeds: np.ndarray) -> Frames:
    """The frames of N CC points from their normals and feed directions (N, 3) (any length).
    A feed along the normal has no tangent part: it raises ValueError."""
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    n = n / np.linalg.norm(n, axis=1)[:, None]
    d = np.broadcast_to(np.asarray(feeds, dtype=float), n.shape)
    f = d - np.einsum("ij,ij->i", d, n)[:, None] * n
    length = np.linalg.norm(f, axis=1)
    if (length <= _EPS * np.maximum(np.linalg.norm(d, axis=1), 1.0)).any():
        raise ValueError("a feed direction has no part in the tangent plane")
    f = f / length[:, None]
    return Frames(f, n, np.cross(n, f))


def axes_from_angles(frames: Frames, lead: np.ndarray, tilt: np.ndarray,
                     point: np.ndarray | None = None) -> np.ndarray:
    """(M, 3) unit tool axes (part frame) at angles `lead`, `tilt` (M,) rad in the frame of
    row `point[k]` of `frames` (`point` None: row k itself, M = N)."""
    lead, tilt = np.asarray(lead, dtype=float), np.asarray(tilt, dtype=float)
    k = np.arange(len(lead)) if point is None else np.asarray(point)
    ct = np.cos(tilt)[:, None]
    return (ct * np.sin(lead)[:, None] * frames.f[k] + np.sin(tilt)[:, None] * frames.s[k]
            + ct * np.cos(lead)[:, None] * frames.n[k])


def angles_from_axes(frames: Frames, axes: np.ndarray,
                     point: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(lead, tilt) (M,) rad of unit axes (M, 3) in the frames of rows `point` (None: M = N)."""
    a = np.asarray(axes, dtype=float).reshape(-1, 3)
    a = a / np.linalg.norm(a, axis=1)[:, None]
    k = np.arange(len(a)) if point is None else np.asarray(point)
    af = np.einsum("ij,ij->i", a, frames.f[k])
    an = np.einsum("ij,ij->i", a, frames.n[k])
    as_ = np.einsum("ij,ij->i", a, frames.s[k])
    return np.arctan2(af, an), np.arcsin(np.clip(as_, -1.0, 1.0))
