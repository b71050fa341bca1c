"""The cusp height of Jun, Lee and Cha (2002) at a tool orientation (docs/MATH.md §10.3): the
effective cutting profile is the cutter seen along the feed direction, i.e. the lower boundary of
its projection onto the (s, n) plane of the CC frame (the cutting ellipse of a flat end-mill's
bottom, Jun, Lee and Cha 2002 eq. 1, with the side's silhouette), and the cusp between this pass and
the next one, a step-over to either side with the same orientation, is the height of the material
left between them above the surface (Jun, Lee and Cha 2002, eqs. 3 and 9: the larger of the left and
right cusps). The surface across the feed is its osculating parabola (normal curvature `curvature`
along s; 0: the tangent plane) and the neighbour pass is this profile moved along s and lifted onto
it. mm, part frame."""

from __future__ import annotations

import numpy as np

from checker.five_axis.lead_tilt import Frames
from checker.mesh import tool_pieces

_ROWS = 512      # rows per block (the profile samples of a block are held at once)
_HALF = 200      # cusp evaluation points per step-over


def profile(cutter, frames: Frames, point: np.ndarray, axes: np.ndarray,
            phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cutter touching CC row `point[k]` at unit axis `axes[k]`: (x, y) (M, len(phi)) mm,
    its support points (x along s, y along n from the CC point) in the directions
    sin(phi) s - cos(phi) n; for phi from -pi/2 to pi/2 the lower boundary of its projection
    along the feed, x nondecreasing (the body as its core grown by a ball, `checker.mesh.tool`;
    its top capped at 4 diameters, far above any cusp)."""
    body = tool_pieces(cutter, with_holder=False)
    prof = body.prof[0, : body.nprof[0]].copy()
    prof[:, 1] = np.minimum(prof[:, 1], 4.0 * float(cutter.d))
    rho = float(body.rho[0])
    s, n = frames.s[point], frames.n[point]
    tips = cutter.tip_from_contact(np.zeros_like(axes), n, axes)
    u = np.sin(phi)[None, :, None] * s[:, None, :] - np.cos(phi)[None, :, None] * n[:, None, :]
    uz = np.einsum("mkj,mj->mk", u, axes)
    perp = u - uz[..., None] * axes[:, None, :]
    pr = np.linalg.norm(perp, axis=2)
    best = np.argmax(pr[..., None] * prof[:, 0] + uz[..., None] * prof[:, 1], axis=2)
    radial = np.where(pr > 1e-12, prof[best, 0] / np.where(pr > 1e-12, pr, 1.0), 0.0)
    p = (tips[:, None, :] + radial[..., None] * perp + prof[best, 1][..., None] * axes[:, None, :]
         + rho * u)
    return np.einsum("mkj,mj->mk", p, s), np.einsum("mkj,mj->mk", p, n)


def _lower(x: np.ndarray, y: np.ndarray, phi: np.ndarray, theta: np.ndarray):
    """The support points (x, y) (M, K) of directions `phi` turned by `theta` (M,) rad about
    the CC point, kept where the turned direction is in [-pi/2, pi/2] (the lower boundary, x
    nondecreasing) and clamped to the ends of that window elsewhere."""
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    xr, yr = c * x - s * y, s * x + c * y
    turned = phi[None, :] + theta[:, None]
    k = np.arange(len(phi))[None, :]
    first = np.argmax(turned >= -0.5 * np.pi, axis=1)[:, None]
    last = (len(phi) - 1 - np.argmax((turned <= 0.5 * np.pi)[:, ::-1], axis=1))[:, None]
    i = np.clip(k, first, last)
    r = np.arange(len(x))[:, None]
    return xr[r, i], yr[r, i]


def _interp_rows(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Per row m the piecewise-linear y(x) at the points `at` (M, J); inf outside x's span."""
    m, k = x.shape
    big = 2.0 * (np.abs(x).max() + np.abs(at).max()) + 1.0
    off = big * np.arange(m)[:, None]
    i = np.searchsorted((x + off).ravel(), (at + off).ravel()).reshape(m, -1)
    i = np.clip(i - k * np.arange(m)[:, None], 1, k - 1)
    r = np.arange(m)[:, None]
    x0, x1, y0, y1 = x[r, i - 1], x[r, i], y[r, i - 1], y[r, i]
    dx = x1 - x0
    t = np.where(dx > 0.0, (at - x0) / np.where(dx > 0.0, dx, 1.0), 0.0)
    out = y0 + np.clip(t, 0.0, 1.0) * (y1 - y0)
    return np.where((at < x[:, :1]) | (at > x[:, -1:]), np.inf, out)


def cusp_heights(cutter, frames: Frames, point: np.ndarray, axes: np.ndarray, stepover: float,
                 curvature: np.ndarray | float = 0.0, samples: int = 1441) -> np.ndarray:
    """(M,) mm: the cusp height (module docstring) of `cutter` at CC row `point[k]` with unit
    axis `axes[k]`, the passes `stepover` mm apart along s, the surface's normal curvature
    across the feed `curvature` (1/mm per CC row, positive where it bends towards the tool; the
    neighbour pass stands on the surface's osculating parabola, its profile turned with the
    surface normal); inf where the step-over is wider than the profile."""
    point = np.asarray(point)
    kappa = np.broadcast_to(np.asarray(curvature, dtype=float), (len(frames.n),))[point]
    w = float(stepover)
    turn = np.arctan(kappa * w)
    margin = float(np.abs(turn).max(initial=0.0)) + 1e-3
    phi = np.linspace(-0.5 * np.pi - margin, 0.5 * np.pi + margin, samples)
    at = np.linspace(-w, w, 2 * _HALF + 1)
    out = np.empty(len(point))
    for b in range(0, len(point), _ROWS):
        sl = slice(b, b + _ROWS)
        x, y = profile(cutter, frames, point[sl], axes[sl], phi)
        k, th = kappa[sl, None], turn[sl]
        ground = 0.5 * k * at[None, :] ** 2
        g = _interp_rows(*_lower(x, y, phi, np.zeros(len(th))), np.broadcast_to(at, ground.shape))
        worst = np.zeros(len(th))
        for side in (1.0, -1.0):  # the neighbour pass to the right (+s), then to the left
            nx, ny = _lower(x, y, phi, side * th)
            nb = _interp_rows(nx + side * w, ny + 0.5 * k * w * w,
                              np.broadcast_to(at, ground.shape))
            between = (at * side >= 0.0)[None, :]
            left = np.where(between, np.minimum(g, nb) - ground, -np.inf)
            worst = np.maximum(worst, left.max(axis=1))
        out[sl] = worst
    return out
