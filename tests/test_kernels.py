"""Imaginary-cutter kernels against an independent root-find (brentq on the size of "P lies on the
surface of the solid of revolution"), built from the thesis's parametric profile (eqs. 2.2-2.4),
plus the limit cases (0, inf, vertical normals, zero denominators): never NaN."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from checker import kernels
from checker.cutter import Cutter, parse_cutter

BIG = 1e4


def profile(ball: bool, s: float, r: float, psi: float, theta: float, z: float) -> float:
    """Radius of the cutter of size s at height z above its tip (thesis eqs. 2.2-2.4 with the
    points C, O1, B); -inf below the tip."""
    R, rr = (0.0, s) if ball else (s, r)
    z_o = R * math.tan(psi) + rr / math.cos(psi)
    z_c = (R + rr * math.sin(psi)) * math.tan(psi)
    z_b = z_o - rr * math.sin(theta)
    if z < 0.0:
        return -math.inf
    if z <= z_c:
        return z / math.tan(psi) if psi > 0 else R
    if z <= z_b:
        return R + math.sqrt(max(rr * rr - (z_o - z) ** 2, 0.0))
    return R + rr * math.cos(theta) + (z - z_b) * math.tan(theta)


def placement(c: Cutter, s: float, n: np.ndarray, e: np.ndarray | None):
    """Axis point (x, y) and tip height of the size-s cutter touching the origin with normal n."""
    ball = c.kind in ("ball", "tapered_ball")
    R, rr = (0.0, s) if ball else (s, c.r)
    if not ball and c.psi > 0 and n[2] > math.cos(c.psi):
        return np.zeros(2), 0.0  # the cone vertex touches
    nh = math.hypot(n[0], n[1])
    eh = n[:2] / nh if nh > 1e-9 else (np.zeros(2) if e is None else e[:2])
    o = rr * n
    return o[:2] + R * eh, o[2] - R * math.tan(c.psi) - rr / math.cos(c.psi)


def oracle(c: Cutter, p: np.ndarray, n: np.ndarray, e=None, tol: float = 0.0) -> float:
    """Smallest size whose cutter (corner shrunk by tol about the same centre) contains p."""
    ball = c.kind in ("ball", "tapered_ball")

    def g(s: float) -> float:
        axis, tip_z = placement(c, s, n, e)
        rho = math.hypot(*(p[:2] - axis))
        if ball:
            prof = _shrunk_ball(s, c.theta, tol, p[2] - tip_z)
        else:
            prof = _shrunk(c, s, tol, p[2] - tip_z)
        return min(rho - prof, 1e9)

    if g(0.0) < 0.0:
        return 0.0
    if g(BIG) >= 0.0:
        return math.inf
    return brentq(g, 0.0, BIG, xtol=1e-13, rtol=1e-13)


def _shrunk(c: Cutter, s: float, tol: float, z: float) -> float:
    """APT profile with the corner shrunk to r - tol about the same fillet centre (r >= tol)."""
    if tol == 0.0:
        return profile(False, s, c.r, c.psi, c.theta, z)
    z_o = s * math.tan(c.psi) + c.r / math.cos(c.psi)
    # same centre, smaller corner: the profile of corner r - tol lifted so its centre stays put
    lift = z_o - (s * math.tan(c.psi) + (c.r - tol) / math.cos(c.psi))
    return profile(False, s, c.r - tol, c.psi, c.theta, z - lift)


def _shrunk_ball(s: float, theta: float, tol: float, z: float) -> float:
    if s < tol:  # the sphere has vanished; the inward offset of the taper line remains
        return (z - s) * math.tan(theta) + (s - tol) / math.cos(theta) if theta > 0 else -math.inf
    return profile(True, s - tol, 0.0, 0.0, theta, z - tol)


def mixed_points(rng, m: int, centre: np.ndarray, scales=(12.0, 4.0, 1.0)) -> np.ndarray:
    """m points in boxes of several sizes about `centre` (far, near and very near)."""
    k = len(scales)
    parts = [centre + rng.uniform(-s, s, (m // k + 1, 3)) for s in scales]
    return np.concatenate(parts)[:m]


def random_normals(rng, m: int, nz_lo: float, nz_hi: float) -> np.ndarray:
    nz = rng.uniform(nz_lo, nz_hi, m)
    a = rng.uniform(0, 2 * math.pi, m)
    h = np.sqrt(1 - nz**2)
    return np.stack([h * np.cos(a), h * np.sin(a), nz], axis=1)


CASES = {
    "flat": "CUTTER/10",
    "bullnose": "CUTTER/12,2",
    "ball": "CUTTER/10,5",
    "tapered_ball": "CUTTER/9.16331,5,0,5,0,5,60",
    "tapered_bullnose": f"CUTTER/{2 * 4 + 2 * 3 * math.tan(math.radians(42.5)):.9f},3,4,3,0,5,60",
    "apt": "CUTTER/1,1.5,3,1,10,5,60",  # d, f fixed below from the model
    "drill": "CUTTER/6.5,0,3.25,1.952797,31,0,105",
}


def _cutter(name: str) -> Cutter:
    if name == "apt":
        psi, th = math.radians(10), math.radians(5)
        R, r = 3.0, 1.5
        d = 2 * R + 2 * r * math.sin(math.pi / 4 - th / 2 + psi / 2) / math.cos(
            math.pi / 4 - th / 2 - psi / 2
        )
        f = R * math.tan(psi) + r / math.cos(psi)
        return parse_cutter(f"CUTTER/{d!r},{r},{R},{f!r},10,5,60")
    return parse_cutter(CASES[name])


def _check_against_oracle(c: Cutter, p, n, e=None, tol=0.0):
    got = c.imaginary_size(p, np.zeros_like(p), n, e, tol=tol)
    assert not np.isnan(got).any()
    want = np.array(
        [oracle(c, p[i], n[i], None if e is None else e[i], tol) for i in range(len(p))]
    )
    fin = np.isfinite(want) & (want < BIG / 2)
    assert np.array_equal(np.isinf(got) | (got > BIG / 2), ~fin | (want > BIG / 2))
    np.testing.assert_allclose(got[fin], want[fin], rtol=1e-7, atol=1e-8)
    return got, want


@pytest.mark.parametrize("name", ["flat", "bullnose", "tapered_bullnose", "apt"])
def test_apt_family_fillet_contact_matches_root_find(name):
    c = _cutter(name)
    rng = np.random.default_rng(sum(map(ord, name)))
    m = 400
    lo = math.sin(c.theta) + 1e-3
    hi = math.cos(c.psi) - 1e-3 if c.psi > 0 else 1.0
    n = random_normals(rng, m, lo, hi)
    p = mixed_points(rng, m, np.array([0.0, 0.0, c.r]))
    got, want = _check_against_oracle(c, p, n)
    # every band and every rule is exercised: finite sizes, zeros and infinities
    assert np.isinf(want).sum() > 5 and (want > 0).sum() > 100
    assert (want == 0).sum() > 5 or c.r == 0.0  # a size-0 flat end-mill is a line: no interior


@pytest.mark.parametrize("name", ["bullnose", "apt"])
def test_each_band_is_hit(name):
    """Points placed in the taper, fillet and conical bands of the fillet centre O."""
    c = _cutter(name)
    rng = np.random.default_rng(7)
    m = 150
    n = random_normals(rng, m, max(math.sin(c.theta), 0.2), 0.95 * math.cos(c.psi))
    o = c.r * n
    for dz in (2.0, -0.5 * c.r * (math.sin(c.theta) + math.cos(c.psi)), -1.5 * c.r):
        p = o + np.column_stack([rng.uniform(-8, 8, (m, 2)), np.full(m, dz)])
        got, want = _check_against_oracle(c, p, n)
        if c.psi == 0.0 and dz < -c.r:
            assert np.isinf(want).all()  # below a flat bottom nothing is ever cut
        else:
            assert (np.isfinite(want) & (want > 0)).sum() > 20


@pytest.mark.parametrize("name", ["drill", "apt"])
def test_tip_contact_matches_root_find(name):
    c = _cutter(name)
    rng = np.random.default_rng(11)
    m = 400
    n = random_normals(rng, m, math.cos(c.psi) + 1e-3, 1.0)
    p = mixed_points(rng, m, np.array([0, 0, 4.0]), (8.0, 4.0))
    got, want = _check_against_oracle(c, p, n)
    assert (np.isfinite(want) & (want > 0)).sum() > 50
    assert (want == 0).sum() > 5 or c.r == 0.0  # a size-0 drill is a point


@pytest.mark.parametrize("name", ["ball", "tapered_ball"])
def test_ball_family_matches_root_find(name):
    c = _cutter(name)
    rng = np.random.default_rng(3)
    m = 500
    n = random_normals(rng, m, math.sin(c.theta) + 1e-3, 1.0)
    p = mixed_points(rng, m, np.zeros(3), (10.0, 2.0))
    if c.theta > 0:  # a few points just inside the tip cone
        p[:20] = np.column_stack([rng.uniform(-0.05, 0.05, (20, 2)), rng.uniform(2, 9, 20)])
    got, want = _check_against_oracle(c, p, n)
    assert (np.isfinite(want) & (want > 0)).sum() > 200
    if c.theta > 0:
        assert (want == 0).sum() > 5  # inside the tip cone


def test_depth_tolerance_matches_shrunk_cutter():
    rng = np.random.default_rng(5)
    m = 300
    for name, tol in (("bullnose", 0.05), ("apt", 0.2), ("ball", 0.01), ("tapered_ball", 0.1)):
        c = _cutter(name)
        lo = math.sin(c.theta) + 1e-3
        n = random_normals(rng, m, lo, math.cos(c.psi) - 1e-3 if c.psi > 0 else 1.0)
        p = rng.uniform(-10, 10, (m, 3))
        _check_against_oracle(c, p, n, tol=tol)


def test_depth_tolerance_ignores_noise_on_a_floor():
    """Floor points raised by rounding noise (1e-13 mm, slope below kernels.PLANE_SLOPE) lie on
    the tangent plane: no size, with or without a depth tolerance. Raised by 1e-6 mm (a slope
    above it) they are cut by the flat end-mill of half their distance (worst case over e), and
    a depth tolerance of 1e-6 mm ignores them again."""
    c = parse_cutter("CUTTER/10")
    rng = np.random.default_rng(2)
    p = np.column_stack([rng.uniform(-20, 20, (200, 2)), np.full(200, 1e-13)])
    n = np.tile([0.0, 0.0, 1.0], (200, 1))
    cc = np.zeros((200, 3))
    d = np.linalg.norm(p[:, :2], axis=1)
    assert np.all(np.isinf(c.imaginary_size(p, cc, n)))
    assert np.all(np.isinf(c.imaginary_size(p, cc, n, tol=1e-6)))
    p[:, 2] = 1e-6
    np.testing.assert_allclose(c.imaginary_size(p, cc, n), d / 2, rtol=1e-9)
    assert np.all(np.isinf(c.imaginary_size(p, cc, n, tol=1e-6)))


def test_vertical_normal_uses_e_or_worst_case():
    c = parse_cutter("CUTTER/12,2")
    rng = np.random.default_rng(9)
    m = 200
    n = np.tile([0.0, 0.0, 1.0], (m, 1))
    p = rng.uniform(-10, 10, (m, 3))
    ang = rng.uniform(0, 2 * math.pi, m)
    e = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(m)])
    got_e, _ = _check_against_oracle(c, p, n, e)
    worst = c.imaginary_size(p, np.zeros_like(p), n)
    assert np.all(worst <= got_e + 1e-12)
    # the worst case is the root-find with e along the horizontal offset from the fillet centre
    d = p[:, :2] - 0.0
    e_d = np.column_stack([d / np.linalg.norm(d, axis=1, keepdims=True), np.zeros(m)])
    want = np.array([oracle(c, p[i], n[i], e_d[i]) for i in range(m)])
    fin = np.isfinite(want)
    np.testing.assert_allclose(worst[fin], want[fin], rtol=1e-7, atol=1e-8)
    assert np.all(np.isinf(worst[~fin]))


def test_known_values():
    ball = parse_cutter("CUTTER/10,5")
    # ball in a concave spherical bowl of radius 7 (centre (0,0,7)): any rim point gives r = 7
    q = np.array([[7 * math.sin(0.5), 0.0, 7 - 7 * math.cos(0.5)]])
    n = np.array([[0.0, 0.0, 1.0]])
    assert ball.imaginary_size(q, np.zeros((1, 3)), n)[0] == pytest.approx(7.0, rel=1e-12)
    # bull-nose r=2 on a floor beside a vertical wall at x = 5: the cutter with its axis at
    # x = R and outer radius R + r reaches the wall when 2R + r = 5
    bull = parse_cutter("CUTTER/12,2")
    wall_pts = np.array([[5.0, 0.0, 3.0], [5.0, 0.0, 30.0]])
    out = bull.imaginary_size(
        wall_pts, np.zeros((2, 3)), np.repeat(n, 2, 0), np.array([[1.0, 0, 0]] * 2)
    )
    np.testing.assert_allclose(out, 1.5, rtol=1e-12)
    # flat end-mill beside a vertical wall at x = 5 above a floor CC at the origin:
    flat = parse_cutter("CUTTER/20")
    wall = np.array([[5.0, 0.0, 3.0]])
    assert flat.imaginary_size(wall, np.zeros((1, 3)), n, np.array([[1.0, 0, 0]]))[0] == 2.5


def test_limit_cases_never_nan():
    c = _cutter("apt")
    zero = np.zeros((1, 3))
    up = np.array([[0.0, 0.0, 1.0]])
    # normal facing away or steeper than the taper: cannot be cut -> 0
    for nn in ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.999, 0, 0.04471]):
        v = np.array([nn]) / np.linalg.norm(nn)
        assert c.imaginary_size(np.array([[1.0, 2, 3]]), zero, v)[0] == 0.0
    # below the tangent plane -> inf; the CC point itself -> inf (on the plane)
    assert np.isinf(c.imaginary_size(np.array([[1.0, 0, -1]]), zero, up)[0])
    assert np.isinf(c.imaginary_size(zero, zero, up)[0])
    # flat bottom, point on the bottom plane: never cut
    flat = parse_cutter("CUTTER/10")
    assert np.isinf(flat.imaginary_size(np.array([[3.0, 0, 0]]), zero, up)[0])
    # tapered ball: wall exactly parallel to the taper (e1 = 0) and inside the tip cone
    tb = _cutter("tapered_ball")
    nw = np.array([[-math.cos(tb.theta), 0.0, math.sin(tb.theta)]])
    p = np.array([[-2.0, 0.0, 5.0], [0.1, 0.0, 5.0], [3.0, 1.0, 2.0]])
    out = tb.imaginary_size(p, np.zeros((3, 3)), np.repeat(nw, 3, axis=0))
    assert not np.isnan(out).any()
    assert tb.imaginary_size(np.array([[0.1, 0, 5.0]]), zero, up)[0] == 0.0


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=6, max_size=6),
    st.sampled_from(sorted(CASES)),
    st.floats(0.0, 0.5),
)
def test_random_inputs_never_nan(v, name, tol):
    c = _cutter(name)
    p = np.array([v[:3]])
    n = np.array([v[3:]])
    nrm = np.linalg.norm(n)
    n = n / nrm if nrm > 0 else np.array([[0.0, 0.0, 1.0]])
    out = c.imaginary_size(p, np.zeros((1, 3)), n, tol=tol)
    assert not np.isnan(out).any() and out[0] >= 0.0


@settings(max_examples=30, deadline=None)
@given(
    st.floats(0.0, 4.0),
    st.floats(0.0, 30.0),
    st.floats(0.0, 20.0),
    st.sampled_from([0.0, 0.05]),
    st.booleans(),
    st.integers(0, 2**31),
)
def test_random_cutters_match_root_find(r, psi_deg, th_deg, tol, ball, seed):
    """Any corner radius, bottom and taper angle (and the ball family with any taper)."""
    if ball:
        c = Cutter("tapered_ball" if th_deg else "ball", 1.0, 1.0, 0.0, 0.0, math.radians(th_deg))
    else:
        psi = math.radians(psi_deg)
        th = math.radians(th_deg)
        c = Cutter("apt", 10.0, r, 3.0, psi, th, 50.0)
        if r < tol:
            tol = 0.0  # the oracle shrinks a corner about its centre: needs r >= tol
    rng = np.random.default_rng(seed)
    m = 25
    lo = math.sin(c.theta) + 1e-3
    n = random_normals(rng, m, lo, 1.0)
    p = mixed_points(rng, m, np.zeros(3), (10.0, 3.0))
    _check_against_oracle(c, p, n, tol=tol)


def test_zero_denominators():
    """e.d + k = 0 exactly (P on the limiting surface of the R -> inf cutter): inf, not NaN;
    a tapered-ball wall parallel to the taper (n_z = sin(theta), e1 = 0): the linear root."""
    bull = parse_cutter("CUTTER/12,2")
    up = np.array([[0.0, 0.0, 1.0]])
    e = np.array([[1.0, 0.0, 0.0]])
    p = np.array([[-2.0, 1.0, 2.0], [-3.0, 0.0, 2.0], [-1.0, 0.0, 2.0]])
    out = bull.imaginary_size(p, np.zeros((3, 3)), np.repeat(up, 3, 0), np.repeat(e, 3, 0))
    assert np.isinf(out[0]) and np.isinf(out[1]) and out[2] == 0.0
    tb = _cutter("tapered_ball")
    s, co = math.sin(tb.theta), math.cos(tb.theta)
    rng = np.random.default_rng(12)
    m = 200
    ang = rng.uniform(0, 2 * math.pi, m)
    n = np.column_stack([co * np.cos(ang), co * np.sin(ang), np.full(m, s)])
    p = mixed_points(rng, m, np.zeros(3), (10.0, 3.0))
    _, want = _check_against_oracle(tb, p, n)
    assert (np.isfinite(want) & (want > 0)).sum() > 20


def test_parallel_kernels_equal_serial():
    """Above PARALLEL_MIN pairs the threaded kernels run; they give the serial answers."""
    c = _cutter("apt")
    rng = np.random.default_rng(13)
    k = kernels.PARALLEL_MIN + 5000
    p = rng.uniform(-10, 10, (k, 3))
    cc = rng.uniform(-1, 1, (k, 3))
    n = random_normals(rng, k, 0.1, 1.0)
    prm = c.kernel_params()
    e = np.zeros((1, 3))
    got = c.imaginary_size(p, cc, n)
    np.testing.assert_array_equal(got, kernels._pair_sizes_ser(p, cc, n, e, False, 0, prm))
    assert np.isfinite(got).sum() > 1000 and (got > 0).sum() > 1000


def test_conical_band_uses_corrected_k():
    """docs/MATH.md §4 erratum 3: in the conical band k = dz cot(psi) + r csc(psi); the
    thesis's printed eq. 2.30 (dz / tan(psi) + 2 r sin(psi)) gives a different size, the
    root-find agrees with the corrected one."""
    c = _cutter("apt")
    r, psi = c.r, c.psi
    n = np.array([[-0.3, 0.0, math.sqrt(1 - 0.09)]])
    o = r * n[0]
    p = np.array([[o[0] - 4.0, 0.5, o[2] - 1.2 * r]])  # dz = -1.2 r: conical band
    got = c.imaginary_size(p, np.zeros((1, 3)), n)[0]
    want = oracle(c, p[0], n[0])
    d = p[0, :2] - o[:2]
    e = n[0, :2] / np.linalg.norm(n[0, :2])
    dz = p[0, 2] - o[2]
    k_thesis = dz / math.tan(psi) + 2 * r * math.sin(psi)
    r_thesis = (d @ d - k_thesis**2) / (2 * (e @ d + k_thesis))
    assert got == pytest.approx(want, rel=1e-9)
    assert 0 < got < 100 and abs(r_thesis - want) > 0.05 * want


@pytest.mark.parametrize("name", ["CUTTER/10", "CUTTER/10,2", "CUTTER/12,3", "CUTTER/8,4"])
def test_plane_disc_bound_is_below_every_size_in_its_disc(name):
    """`plane_disc_bound` (the contour crossings' skip) never exceeds `apt_size` at any point of
    its disc on the plane (sampled densely, boundary included), and with a zero radius it is
    `apt_size` at the centre itself wherever that is positive and finite (not a vacuous bound)."""
    c = parse_cutter(name)
    prm = c.kernel_params()
    rng = np.random.default_rng(31)
    checked = tight = 0
    for trial in range(400):
        if trial % 5 == 0:  # vertical normals: e from the caller, or none (worst case)
            n = np.array([0.0, 0.0, 1.0])
            ang = rng.uniform(0, 2 * math.pi)
            e = np.array([math.cos(ang), math.sin(ang)]) if trial % 10 else np.zeros(2)
        else:
            n = rng.normal(size=3)
            n[2] = abs(n[2]) + 0.05
            n /= np.linalg.norm(n)
            e = np.zeros(2)
        qz = rng.uniform(-1.0, 3.0)
        pd = kernels.plane_disc(qz, *n, *e, prm)
        qx, qy = rng.uniform(-15.0, 15.0, 2)
        rho = rng.uniform(0.0, 2.0)
        bound = kernels.plane_disc_bound(pd, qx, qy, rho)
        ang = rng.uniform(0, 2 * math.pi, 64)
        rad = rho * np.sqrt(np.r_[rng.uniform(0, 1, 48), np.ones(16)])
        sizes = [kernels.apt_size(qx + a * math.cos(t), qy + a * math.sin(t), qz, *n, *e,
                                  True, prm) for a, t in zip(rad, ang, strict=True)]
        assert bound <= min(sizes) + 1e-9 * (1.0 + abs(min(sizes))), (trial, bound, min(sizes))
        checked += 1
        at_q = kernels.apt_size(qx, qy, qz, *n, *e, True, prm)
        if 0.0 < at_q < math.inf:
            exact = kernels.plane_disc_bound(pd, qx, qy, 0.0)
            assert exact == pytest.approx(at_q, rel=1e-9, abs=1e-12)
            tight += 1
    assert checked == 400 and tight > 100


def test_plane_disc_bound_is_none_where_every_size_can_be_zero():
    """A normal too flat for the family (n_z <= 0) or a cutter with a cone bottom (psi > 0):
    no bound (-inf), as `apt_size` can be 0 there."""
    flat = parse_cutter("CUTTER/10").kernel_params()
    assert kernels.plane_disc_bound(kernels.plane_disc(0.5, 1.0, 0.0, 0.0, 0.0, 0.0, flat),
                                    50.0, 0.0, 0.1) == -math.inf
    cone = parse_cutter("CUTTER/10,1,4,2.10707,15,0,40").kernel_params()
    assert kernels.plane_disc_bound(kernels.plane_disc(0.5, 0.0, 0.0, 1.0, 1.0, 0.0, cone),
                                    50.0, 0.0, 0.1) == -math.inf
