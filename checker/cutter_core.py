"""The cutter's solid (`Cutter.core`): every cutter of the APT family with a flat or conical
bottom is its core, a solid of revolution of a wedge in the profile plane, grown by a ball of
the corner radius r. The core's wedge has its corner at the fillet centre C = (rho = R,
h = h_O), h_O = R tan(psi) + r sec(psi) above the tip; its lower side rises from C towards the
axis with slope tan(psi) (the bottom offset by r), its outer side leaves C upwards with taper
theta (the side offset by r). Signed distance to the cutter = distance to the core - r (exact
outside the core; inside it, minus r plus the depth inside the core; at a conical tip, psi > 0,
the grown core is rounded where the real tip is sharp, short of it by r (sec(psi) - 1) along
the axis). Used by the contact search (`geometry.contact`: the projection and the sides'
normals, `core_sides`), the cutter's own signed distance and the mesh checks' tool pieces
(`checker.mesh.tool`: the wedge's profile, `Core.profile`). Points (N,3) in mm, in the part
frame with the tool's tips and unit axes (N,3), or in the tool frame with tips 0 and axes +z.
(docs/MATH.md §2)"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


@dataclass(frozen=True)
class Core:
    """The core of a cutter: corner radius `r`, corner-centre radius `R`, bottom cone angle
    `psi` and taper angle `theta` (rad); mm. `h_o` is the corner-centre height above the tip.
    r and R may be (N,) arrays: the cores of N cutters of one family (`Cutter.cores`)."""

    r: float | np.ndarray
    R: float | np.ndarray
    psi: float = 0.0
    theta: float = 0.0

    @property
    def h_o(self) -> float:
        return self.R * np.tan(self.psi) + self.r / np.cos(self.psi)

    def profile(self, top: float) -> tuple[np.ndarray, np.ndarray]:
        """The wedge's half-profile closed at height `top` (mm above the tip; raised to the
        corner centre where lower) and the radius it is grown by: (vertices (N, 4, 2)
        counter-clockwise (rho, h): the lower side's end on the axis (0, r sec(psi)), the
        corner centre C, the outer side at `top`, the axis at `top`; grow (N,) = r). A ball's
        vertices repeat (R = 0): `checker.mesh.tool` drops the repeats."""
        r = np.atleast_1d(np.asarray(self.r, dtype=np.float64))
        R = np.broadcast_to(np.asarray(self.R, dtype=np.float64), r.shape)
        h0 = r / math.cos(self.psi)                 # the lower side meets the axis
        ho = R * math.tan(self.psi) + h0            # corner centre height
        top = np.maximum(top, ho)
        out = np.zeros((len(r), 4, 2))
        out[:, 0, 1] = h0
        out[:, 1, 0], out[:, 1, 1] = R, ho
        out[:, 2, 0], out[:, 2, 1] = R + (top - ho) * math.tan(self.theta), top
        out[:, 3, 1] = top
        return out, r.copy()


class CoreSides(NamedTuple):
    """The core's two sides seen from N points (N,3 arrays in the points' frame): `lower` and
    `outer` the outward unit normals of the lower side (the bottom offset by r) and of the
    outer side (the side offset by r), `below` and `beyond` the points' signed distances past
    each side's line (> 0 outside)."""

    lower: np.ndarray
    outer: np.ndarray
    below: np.ndarray
    beyond: np.ndarray


def _side_normals(core: Core) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normals (rho, h) of the wedge's lower side and outer side."""
    n1 = np.array([np.sin(core.psi), -np.cos(core.psi)])
    n3 = np.array([np.cos(core.theta), -np.sin(core.theta)])
    return n1, n3


def core_sides(core: Core, h: np.ndarray, rho: np.ndarray, w: np.ndarray,
               axes: np.ndarray) -> CoreSides:
    """The `CoreSides` of points at height h above the tip, radial distance rho and unit
    radial direction w (`tool_coordinates`), tool axes `axes` (N,3)."""
    n1, n3 = _side_normals(core)
    dr, dh = rho - core.R, h - core.h_o
    return CoreSides(n1[0] * w + n1[1] * axes, n3[0] * w + n3[1] * axes,
                     dr * n1[0] + dh * n1[1], dr * n3[0] + dh * n3[1])


@dataclass
class CoreProjection:
    """Nearest core points of N points: `q (N,3)` on the core, `dist (N,)` (0 inside the core),
    `hess (N,3,3)` the Hessian of dist^2/2 with respect to the point (exact for psi = theta = 0,
    the in-plane part exact and the circumferential part approximate otherwise), `signed (N,)`
    the distance, negative inside the core (minus the distance to its boundary), `gap (N,)` the
    signed distance to the cutter (the core grown by r)."""

    q: np.ndarray
    dist: np.ndarray
    hess: np.ndarray
    signed: np.ndarray
    gap: np.ndarray


def tool_coordinates(points: np.ndarray, tips: np.ndarray, axes: np.ndarray):
    """Height h above the tip, radial distance rho and unit radial direction w (N,3)."""
    d = points - tips
    h = np.einsum("ij,ij->i", d, axes)
    wv = d - h[:, None] * axes
    rho = np.linalg.norm(wv, axis=1)
    # any direction perpendicular to the axis where the point is on it
    perp = np.cross(axes, np.where(np.abs(axes[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    perp /= np.linalg.norm(perp, axis=1)[:, None]
    safe = rho > 1e-12
    w = np.where(safe[:, None], wv / np.where(safe, rho, 1.0)[:, None], perp)
    return h, rho, w


def _profile_nearest(core: Core, rho: np.ndarray, h: np.ndarray):
    """Nearest point (rq, hq) of the core's wedge in the profile plane, which piece holds it
    (0 inside, 1 lower side, 2 corner C, 3 outer side), and for inside points minus their
    distance to the wedge's boundary (the wedge is convex: the nearer of its two sides)."""
    R, ho = core.R, core.h_o
    n1, n3 = _side_normals(core)
    # lower side: from C towards the axis, direction t1 = (-cos psi, -sin psi)
    t1 = np.array([-np.cos(core.psi), -np.sin(core.psi)])
    # outer side: from C upwards, direction t3 = (sin theta, cos theta)
    t3 = np.array([np.sin(core.theta), np.cos(core.theta)])
    dr, dh = rho - R, h - ho
    s1 = dr * n1[0] + dh * n1[1]          # > 0 below the lower side
    s3 = dr * n3[0] + dh * n3[1]          # > 0 outside the outer side
    a1 = dr * t1[0] + dh * t1[1]          # along the lower side from C
    a3 = dr * t3[0] + dh * t3[1]          # along the outer side from C
    len1 = R / np.cos(core.psi)           # the lower side reaches the axis
    piece = np.zeros(rho.shape, dtype=np.int8)
    on1 = (s1 > 0) & (a1 > 0)
    on3 = (s3 > 0) & (a3 > 0) & ~on1
    corner = ((s1 > 0) | (s3 > 0)) & ~on1 & ~on3
    piece[on1], piece[corner], piece[on3] = 1, 2, 3
    a1c = np.minimum(a1, len1)
    rq = np.where(on1, R + a1c * t1[0], np.where(on3, R + a3 * t3[0], np.where(corner, R, rho)))
    hq = np.where(on1, ho + a1c * t1[1], np.where(on3, ho + a3 * t3[1], np.where(corner, ho, h)))
    depth = np.where(piece == 0, np.maximum(s1, s3), 0.0)   # inside: minus the distance to a side
    return rq, hq, piece, (n1, n3), depth


def project_to_core(
    core: Core, points: np.ndarray, tips: np.ndarray, axes: np.ndarray
) -> CoreProjection:
    """Nearest core point of each point (N,3), its distance and the Hessian of dist^2/2."""
    h, rho, w = tool_coordinates(points, tips, axes)
    rq, hq, piece, (n1, n3), depth = _profile_nearest(core, rho, h)
    q = tips + hq[:, None] * axes + rq[:, None] * w
    dist = np.hypot(rho - rq, h - hq)
    aa = np.einsum("ni,nj->nij", axes, axes)
    ww = np.einsum("ni,nj->nij", w, w)
    circ = np.eye(3)[None] - aa - ww
    # in-plane Hessian: n n^T on a side, the identity at the corner, zero inside
    nl = np.where((piece == 1)[:, None], n1[0] * w + n1[1] * axes, n3[0] * w + n3[1] * axes)
    inplane = np.where((piece == 2)[:, None, None], aa + ww, np.einsum("ni,nj->nij", nl, nl))
    inplane = np.where((piece == 0)[:, None, None], 0.0, inplane)
    ratio = np.where(rho > 1e-12, 1.0 - rq / np.where(rho > 1e-12, rho, 1.0), 0.0)
    hess = inplane + np.where((piece == 0)[:, None, None], 0.0, ratio[:, None, None] * circ)
    signed = np.where(piece == 0, depth, dist)
    return CoreProjection(q, dist, hess, signed, signed - core.r)


def signed_distance(
    core: Core, points: np.ndarray, tips: np.ndarray, axes: np.ndarray
) -> np.ndarray:
    """Signed distance (N,) mm of each point to the cutter solid (negative inside), via the core:
    exact, inside too (the core is convex, so a point t inside it is t + r inside the cutter)."""
    return project_to_core(core, points, tips, axes).gap
