"""The curvature limit at the CC point in closed form (checker/engine/refine/limits.py, docs/MATH.md
§3.7) against the size function itself: on free-form patches (tests/engine_parts.free_form), at
CC points with the tool axis along +z and tilted, for a ball, a bull-nose and a flat end-mill,
the limit equals the smallest size over a ring of surface points around Pcc extrapolated to the
ring's radius 0 (Richardson: 2 s(rho/2) - s(rho) removes the third-order term), the ring's
minimum found by a 1,440-direction scan refined by Brent's method (scipy), and for the flat
end-mill at the ring's crossings of the bottom plane (root-found). The sizes come from
the cutter's own point kernel (`Cutter.imaginary_size`), not from the closed form."""

from __future__ import annotations

import numpy as np
import pytest
from engine_parts import free_form
from scipy.optimize import brentq, minimize_scalar

from checker.cutter import parse_cutter
from checker.engine.grid.rotations import rotate_rows, tool_rotations
from checker.engine.refine.limits import curvature_limit
from checker.engine.sizes import RowFrame, horizontal_e
from checker.geometry.evaluate import evaluate_mixed
from checker.geometry.sampling import sample_part

SEEDS = (27306813, 389757302)
CUTTERS = ("CUTTER/10,5", "CUTTER/10,2", "CUTTER/10")
TILT = np.radians(20.0)
RHO = 4e-3  # mm: the outer ring; the inner one at RHO / 2


@pytest.fixture(scope="module", params=SEEDS)
def rows(request):
    """12 CC points of a fresh part facing both tool axes: (part, cc, normals, sid, uv)."""
    part = free_form(request.param)
    tp = sample_part(part)
    tilted = np.array([np.sin(TILT), 0.0, np.cos(TILT)])
    ok = (tp.normals[:, 2] > 0.5) & (tp.normals @ tilted > 0.5)
    pick = np.random.default_rng(request.param).choice(np.flatnonzero(ok), 12, replace=False)
    return part, tp.points[pick], tp.normals[pick], tp.surface[pick].astype(np.int64), tp.uv[pick]


def _frame(cc, normals, axis):
    Q = tool_rotations(np.broadcast_to(axis, cc.shape))
    n_t = rotate_rows(Q, normals)
    return Q, RowFrame(rotate_rows(Q, cc), n_t, horizontal_e(n_t)[0], None, 1e-3)


def _ring_minimum(cutter, part, Q, frame, i, sid, uv, rho):
    """min over the direction of the size at the surface point rho mm from Pcc (first order)."""
    ev = evaluate_mixed(part, sid[i:i + 1], uv[i:i + 1, 0], uv[i:i + 1, 1])
    J = np.column_stack([ev.du[0], ev.dv[0]])
    t1 = ev.du[0] / np.linalg.norm(ev.du[0])
    t2 = np.cross(ev.normals[0], t1)
    lo, hi = np.array(part.surfaces[sid[i]].domain).T

    def tool_frame_points(theta):
        theta = np.atleast_1d(theta)
        t = np.cos(theta)[:, None] * t1 + np.sin(theta)[:, None] * t2
        step = np.linalg.lstsq(J, t.T, rcond=None)[0].T
        p = np.clip(uv[i] + rho * step, lo, hi)
        pts = evaluate_mixed(part, np.full(len(p), sid[i]), p[:, 0], p[:, 1]).points
        return rotate_rows(np.repeat(Q[i:i + 1], len(p), axis=0), pts)

    def height(theta):
        return tool_frame_points(theta)[:, 2] - frame.cc[i, 2]

    def size(theta):
        q = tool_frame_points(theta)
        return cutter.imaginary_size(q, np.repeat(frame.cc[i:i + 1], len(q), axis=0),
                                     np.repeat(frame.n[i:i + 1], len(q), axis=0),
                                     np.repeat(frame.e[i:i + 1], len(q), axis=0))

    grid = np.linspace(0.0, 2.0 * np.pi, 1440, endpoint=False)
    s = size(grid)
    k = int(np.argmin(s))
    h = grid[1] - grid[0]
    best = minimize_scalar(lambda a: float(size(a)[0]), bounds=(grid[k] - h, grid[k] + h),
                           method="bounded", options={"xatol": 1e-10})
    return min(float(s[k]), float(best.fun), *_on_the_bottom_plane(size, height, grid))


def _on_the_bottom_plane(size, height, grid):
    """The sizes where the ring crosses the height of Pcc (the flat end-mill's bottom plane): a
    point just below it is not cut and just above it is cut by a finite cutter, so the smallest
    size lies on a band of the ring narrower than any scan (docs/MATH.md §3.7)."""
    z = height(grid)
    out, nudges = [], np.array([-1e-9, -1e-10, -1e-11, 1e-11, 1e-10, 1e-9])
    for k in np.flatnonzero(np.sign(z) != np.sign(np.roll(z, -1))):
        root = brentq(lambda a: float(height(a)[0]), grid[k], grid[k] + grid[1], xtol=1e-15)
        out.append(float(np.min(size(root + nudges))))
    return out


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # Brent's method meeting inf sizes
@pytest.mark.parametrize("cutter_text", CUTTERS)
@pytest.mark.parametrize("tilted", [False, True])
def test_the_closed_form_is_the_size_at_radius_zero(rows, cutter_text, tilted):
    part, cc, normals, sid, uv = rows
    axis = np.array([np.sin(TILT), 0.0, np.cos(TILT)]) if tilted else np.array([0.0, 0.0, 1.0])
    cutter = parse_cutter(cutter_text)
    Q, frame = _frame(cc, normals, axis)
    closed = curvature_limit(cutter, part, frame, Q, np.arange(len(cc)), sid, uv).size
    assert np.isfinite(closed).sum() >= 4, closed
    for i in np.flatnonzero(np.isfinite(closed)):
        far = _ring_minimum(cutter, part, Q, frame, i, sid, uv, RHO)
        near = _ring_minimum(cutter, part, Q, frame, i, sid, uv, RHO / 2)
        extrapolated = 2.0 * near - far
        assert abs(closed[i] - extrapolated) <= 1e-5 * closed[i] + 1e-4, (i, closed[i], near, far)
