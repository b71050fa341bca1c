"""Feasible tool orientations per CC point (checker/five_axis, docs/MATH.md §10): closed forms
in a half-pipe, the refined boundary against a brute-force scan (the channel part; the impeller
sample when present), the best orientation where the answer is known."""

from __future__ import annotations

import math

import numpy as np
import pytest
from feasible_brute import brute_force_check
from five_axis_parts import channel, channel_contacts, half_pipe, tool
from mesh_gjk_oracle import gjk_pose_depths

from checker.config import default_config
from checker.five_axis.best_orientation import allowable_objective, best_orientation, cusp_objective
from checker.five_axis.feasible import feasible_region
from checker.five_axis.lead_tilt import angles_from_axes, axes_from_angles, local_frames
from checker.five_axis.poses import PoseJudge
from checker.geometry.sampling import sample_part
from checker.geometry.tessellate import part_triangles
from checker.mesh import MeshIndex
from checker.part import MeshPart, Part

TOL = math.radians(0.01)
BOTTOM = (np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]))


def _triangles(part: Part):
    return part_triangles(part, 0.001, default_config().geometry)


def test_frames_round_trip_and_convention():
    rng = np.random.default_rng(1)
    n = rng.normal(size=(50, 3))
    fr = local_frames(n, rng.normal(size=(50, 3)))
    assert np.allclose(np.einsum("ij,ij->i", fr.f, fr.n), 0.0)
    assert np.allclose(np.cross(fr.n, fr.f), fr.s)
    lead, tilt = rng.uniform(-1.4, 1.4, 50), rng.uniform(-1.4, 1.4, 50)
    back = angles_from_axes(fr, axes_from_angles(fr, lead, tilt))
    assert np.allclose(back, (lead, tilt), atol=1e-12)
    # lead leans towards the feed, tilt towards s = n x f; zero is the normal
    f0 = local_frames([[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.3]])
    assert np.allclose(axes_from_angles(f0, [0.1], [0.0]), [[math.sin(0.1), 0, math.cos(0.1)]])
    assert np.allclose(axes_from_angles(f0, [0.0], [0.1]), [[0, math.sin(0.1), math.cos(0.1)]])
    with pytest.raises(ValueError):
        local_frames([[0.0, 0.0, 1.0]], [[0.0, 0.0, 2.0]])


def test_holder_in_a_half_pipe_closed_form():
    """A ball end-mill (r = 3) with a holder (radius rh = 12 from the stick-out S = 18 to 30
    above the tip; shank radius 3 from the flute length 10) at the bottom of a half-pipe of
    radius rho = 40 (the inside of a cylinder along x, the material outside), tilted sideways
    by T. In the cross-section (y, z) the pipe is the circle of centre O = (0, rho) and every
    tool piece, a cylinder whose axis lies in the plane, projects along x to a rectangle. The
    ball's centre c = (0, r) stays put whatever the axis a = (sin T, cos T); with d = rho - r,
    c - O = (0, -d). The holder's lower outer corner is P = c + (S - r) a + rh a_perp,
    a_perp = (cos T, -sin T); with A = S - r, m = sqrt(A^2 + rh^2), beta = atan2(rh, A),
    P - c = m (sin(T + beta), cos(T + beta)), so |P - O|^2 = m^2 + d^2 - 2 m d cos(T + beta),
    and P reaches the circle at

        T* = acos((m^2 + d^2 - rho^2) / (2 m d)) - beta = 45.769 degrees,

    with P 5 mm above the bottom (below the rim at z = rho = 40; the holder's top stays below
    it too). The other contacts come later: the holder's upper corner (A = 27) at 48.97
    degrees, the shank's corner (A = 7, radius 3) and the body's cap (centre at
    c + (10 - 3) a, radius 3: cos T = 7 / (2 d)) beyond 84 degrees. A convex segment stays in
    the disc when its ends do, so the first contact is a corner: T*. The pipe is 2000 chords
    whose vertices lie on the circle (sag 1.2e-5 mm, inside it: the holder meets the polygon
    first by at most sag / |P - c| = 6e-7 rad); the judge's tolerance 1e-4 mm plus that sag
    moves the crossing later by at most about (1e-4 + 1.2e-5) / |P - c| = 6e-6 rad. Both are
    far below the 0.01-degree bisection tolerance, so the refined crossing, on the feasible
    side, must lie within 0.01 degrees below T*."""
    rho, r, S, rh = 40.0, 3.0, 18.0, 12.0
    d, A = rho - r, S - r
    m, beta = math.hypot(A, rh), math.atan2(rh, A)
    t_star = math.acos((m * m + d * d - rho * rho) / (2 * m * d)) - beta
    assert math.degrees(t_star) == pytest.approx(45.769, abs=1e-3)
    judge = PoseJudge.for_triangles(_triangles(half_pipe(rho, 120.0, 2000)),
                                    tool("CUTTER/6,3", 10.0, 6.0, S, 2 * rh, 12.0), 1e-4)
    reg = feasible_region(judge, *BOTTOM, tolerance=TOL)
    on_line = np.flatnonzero(np.abs(reg.crossing[:, 0]) < 1e-12)  # lead = 0
    tilts = np.sort(reg.crossing[on_line, 1])
    assert len(tilts) == 2
    for got in (-tilts[0], tilts[1]):
        assert t_star - TOL - 1e-5 <= got <= t_star + 1e-5
    assert reg.mask[0, len(reg.leads) // 2, len(reg.tilts) // 2]  # the normal is feasible
    bits = np.unpackbits(reg.packed(), axis=1, count=reg.mask[0].size)
    assert (bits.reshape(reg.mask.shape).astype(bool) == reg.mask).all()


def _ellipse_fit_lead(R: float, rho: float, tau: float) -> float:
    """The least lead (rad) at which a flat end-mill of radius R at the bottom of a pipe of
    radius rho penetrates it by at most tau (docstring of the test below)."""
    def excess(b: float) -> float:  # max over c of |X(c) - O|^2 - rho^2
        c = min(1.0, b * (rho - b) / (R * R - b * b))
        return R * R * (1 - c * c) + (rho - b + b * c) ** 2 - rho * rho
    lo, hi = 0.0, R * R / rho  # excess(hi) = 0 (curvature matched), excess falls with b
    target = 2 * rho * tau + tau * tau
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if excess(mid) <= target else (mid, hi)
    return math.asin(hi / R)


def test_best_cusp_lead_in_a_half_pipe_closed_form():
    """A flat end-mill (R = 5) at the bottom of a half-pipe of radius rho = 40, fed along the
    pipe, leaning along the feed by the lead L (tilt 0). Seen along the feed its bottom is the
    ellipse X(c) = (R sqrt(1 - c^2), b (1 - c)), b = R sin L, touching the circle of centre
    (0, rho) at the bottom (c = 1). |X - O|^2 - rho^2 = (b^2 - R^2) c^2 + 2 b (rho - b) c +
    R^2 + (rho - b)^2 - rho^2 is concave in c, largest at c* = b (rho - b) / (R^2 - b^2):
    with c* >= 1, i.e. b >= R^2 / rho (sin L >= R / rho: the ellipse's curvature radius R^2/b
    at most rho), it fits; else it pokes out by sqrt(rho^2 + excess) - rho. The check allows a
    penetration tau = 1e-4 mm, so the feasible leads are |L| >= L_tau with excess(L_tau) =
    2 rho tau + tau^2 (a root in b, `_ellipse_fit_lead`: 7.05 degrees, against 7.18 without
    tolerance). The pipe's 8000 chords lie within 8e-7 mm of the circle and the judge adds no
    deviation. The cusp falls as the lead falls (the ellipse flattens), so the best orientation
    by the cusp objective is the boundary, |L| = L_tau, to the angle tolerance."""
    rho, R, tau = 40.0, 5.0, 1e-4
    lead = _ellipse_fit_lead(R, rho, tau)
    pipe = half_pipe(rho, 60.0, 8000)
    tri = _triangles(pipe)
    judge = PoseJudge(MeshIndex.build(tri.vertices, tri.triangles),
                      tool("CUTTER/10", 15.0, 10.0, 40.0, 30.0, 20.0), tau)
    reg = feasible_region(judge, *BOTTOM, tilt_range=(0.0, 0.0), tolerance=TOL)
    assert len(reg.crossing) == 2
    assert np.all(np.abs(reg.crossing[:, 0]) <= lead + 1e-5)
    assert np.all(np.abs(reg.crossing[:, 0]) >= lead - TOL - 1e-5)
    fr = local_frames(BOTTOM[1], BOTTOM[2])
    best = best_orientation(reg, judge, *BOTTOM, cusp_objective(judge.cutter, fr, 3.0, 1 / rho))
    assert best.found[0] and best.tilt[0] == 0.0
    assert abs(best.lead[0]) == pytest.approx(lead, abs=TOL + 1e-5)


def _floor_and_wall(y_wall: float, height: float) -> Part:
    v = np.array([[-50, -50, 0], [50, -50, 0], [50, y_wall, 0], [-50, y_wall, 0],
                  [50, y_wall, height], [-50, y_wall, height]], dtype=float)
    t = np.array([[0, 1, 2], [0, 2, 3], [3, 2, 4], [3, 4, 5]])
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    return Part([], mesh=MeshPart(v, t, n / np.linalg.norm(n, axis=1)[:, None]))


def test_best_allowable_beside_a_wall():
    """A ball (r = 3) on a floor 6 mm from a wall 8 mm high, fed along the wall. Its allowable
    radius is the distance to the wall, 6, as long as the axis does not lean towards the wall
    (the sphere's equator is the widest part); leaning towards it by T, the cylinder above the
    equator reaches the wall sooner and the size falls. The CAM's axis leans 40 degrees towards
    the wall (infeasible: the holder hits the wall). The largest allowable is on the plateau
    T <= 0, and among its orientations the one nearest the CAM's axis is lead 0, tilt 0: the
    best, with size 6 (to the engine's tolerance)."""
    part = _floor_and_wall(6.0, 8.0)
    cutter = tool("CUTTER/6,3", 12.0, 6.0, 20.0, 24.0, 20.0)
    judge = PoseJudge.for_triangles(_triangles(part), cutter, 0.01)
    cc, n, f = BOTTOM
    reg = feasible_region(judge, cc, n, f)
    cam = np.array([[0.0, math.sin(math.radians(40)), math.cos(math.radians(40))]])
    assert not judge(cc, n, cam)[0]
    best = best_orientation(reg, judge, cc, n, f,
                            allowable_objective(sample_part(part), part, cutter, cc, n),
                            reference=cam, flat=1e-4)
    assert best.score[0] == pytest.approx(6.0, abs=2e-3)
    assert abs(best.lead[0]) <= TOL and -TOL <= best.tilt[0] <= math.radians(0.02)


def _impeller_cases():
    from conftest import REPO

    folder = REPO / "samples" / "impeller"
    if not folder.is_dir():
        return [pytest.param(None, marks=pytest.mark.skip(reason="samples/impeller not yet"),
                             id="impeller")]
    return [pytest.param(folder, id="impeller")]


def _channel_case():
    cc, n, f = channel_contacts(4)
    return _triangles(channel()), cc, n, f


def _impeller_case(folder):
    """The impeller sample's part and a few of its CC points (cc.csv: x,y,z,nx,ny,nz in path
    order; the feed from one point to the next)."""
    from checker.geometry import load_part

    parts = sorted(folder.glob("*.json")) + sorted(folder.glob("*.stl"))
    rows = np.loadtxt(folder / "cc.csv", delimiter=",", skiprows=1)
    pick = np.linspace(0, len(rows) - 2, 2).astype(int)
    cc, n = rows[pick, :3], rows[pick, 3:6]
    return _triangles(load_part(parts[0])), cc, n, rows[pick + 1, :3] - cc


@pytest.mark.parametrize("folder", [pytest.param("channel", id="channel"), *_impeller_cases()])
def test_boundary_against_a_brute_force_scan(folder):
    """Every refined crossing lies within the stated tolerance of the boundary found by a
    0.1-degree scan of its grid line (the scan judged with the independent GJK depth), and
    the boundary crosses each edge once."""
    tri, cc, n, f = _channel_case() if folder == "channel" else _impeller_case(folder)
    cutter = tool("CUTTER/8,1", 12.0, 8.0, 30.0, 24.0, 30.0)
    reg = feasible_region(PoseJudge.for_triangles(tri, cutter, 0.01), cc, n, f, tolerance=TOL)
    assert 0 < reg.mask.mean() < 1 and len(reg.crossing) > 50
    check = brute_force_check(reg, PoseJudge.for_triangles(tri, cutter, 0.01,
                                                             depths=gjk_pose_depths),
                              cc, n, f)
    assert check.poses > 20 * len(reg.crossing)
    assert float(check.distance.max()) <= TOL + 1e-9
    assert (check.transitions == 1).all()


def test_cusp_of_a_flat_end_mill_is_the_cutting_ellipse():
    """On a plane at tilt 0 the profile is the ellipse of semi-axes R and b = R sin(lead)
    (Jun, Lee and Cha 2002, eq. 1), whose cusp for a step-over w is b (1 - sqrt(1 - w^2 / (4
    R^2)))."""
    from checker.cutter import parse_cutter
    from checker.five_axis.cusp import cusp_heights

    fr = local_frames(np.tile([0.0, 0.0, 1.0], (4, 1)), np.tile([1.0, 0.0, 0.0], (4, 1)))
    lead = np.radians([0.0, 5.0, 10.0, 20.0])
    axes = axes_from_angles(fr, lead, np.zeros(4))
    got = cusp_heights(parse_cutter("CUTTER/10"), fr, np.arange(4), axes, 2.0)
    b = 5.0 * np.sin(lead)
    np.testing.assert_allclose(got, b * (1 - np.sqrt(1 - 4.0 / 100.0)), atol=5e-5)
