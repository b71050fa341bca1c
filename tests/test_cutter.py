"""Cutter statements (APT CUTTER/ 1-, 2-, 7-value, NX TLDATA/MILL), validation with reasons, and
the cutter's own geometry: tip from contact, profile radius, signed distance."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from checker.cutter import Cutter, cutter_from_apt, cutter_from_tldata, parse_cutter
from checker.errors import PathcheckError


def _apt_line(R, r, psi_deg, th_deg, h=50.0) -> str:
    psi, th = math.radians(psi_deg), math.radians(th_deg)
    q = math.pi / 4 - th / 2
    d = 2 * R + 2 * r * math.sin(q + psi / 2) / math.cos(q - psi / 2)
    f = R * math.tan(psi) + r / math.cos(psi)
    return f"CUTTER/{d!r},{r!r},{R!r},{f!r},{psi_deg!r},{th_deg!r},{h!r}"


@pytest.mark.parametrize(
    ("text", "kind", "R", "r"),
    [
        ("CUTTER/10", "flat", 5.0, 0.0),
        ("cutter / 10 , 2", "bullnose", 3.0, 2.0),
        ("CUTTER/10,5", "ball", 0.0, 5.0),
        ("CUTTER/10,0", "flat", 5.0, 0.0),
        ("CUTTER/14.,7.,0,7.,0,0,73.", "ball", 0.0, 7.0),
        ("CUTTER/14.,0,7.,0,0,0,84.", "flat", 7.0, 0.0),
        ("CUTTER/10,2,3,2,0,0,50", "bullnose", 3.0, 2.0),
        ("CUTTER/9.1633,5,0,5,0,5,60", "tapered_ball", 0.0, 5.0),
        ("CUTTER/6.5,0,3.25,1.952797,31.,0,105.", "apt", 3.25, 0.0),
        ("TLDATA/MILL,10.0000,0.0000,50.0000,0.0000,0.0000", "flat", 5.0, 0.0),
        ("TLDATA/MILL,12,2,60,0,0", "bullnose", 4.0, 2.0),
        ("TLDATA/MILL,12,6,60,0,0", "ball", 0.0, 6.0),
        ("TLDATA/MILL,12,2,60,0,0,4,2", "bullnose", 4.0, 2.0),
        ("TLDATA/MILL,12,2,60,0,0,4,2,0.5,5.5,40", "bullnose", 4.0, 2.0),
    ],
)
def test_statements(text, kind, R, r):
    c = parse_cutter(text)
    assert c.kind == kind
    assert pytest.approx(R, abs=1e-12) == c.R
    assert c.r == pytest.approx(r, abs=1e-12)
    assert c.size == (c.r if kind in ("ball", "tapered_ball") else c.R)


def test_seven_value_forms_of_every_kind_round_trip():
    rng = np.random.default_rng(1)
    lines = [_apt_line(3.0, 1.0, 0, 0), _apt_line(0.0, 4.0, 0, 7), _apt_line(0.0, 0.5, 0, 0)]
    for _ in range(30):
        R, r = rng.uniform(0, 10), rng.uniform(0, 4)
        psi, th = rng.uniform(0, 30), rng.uniform(0, 20)
        lines.append(_apt_line(R, r, round(psi, 3), round(th, 3), 80.0))
    for line in lines:
        c = parse_cutter(line)
        assert parse_cutter(c.to_apt()) == c
        # the size family keeps r, psi, theta and moves d with the size (eq. 2.5)
        s = c.with_size(2.5 * c.size + 1.0)
        assert parse_cutter(s.to_apt()) == s
        assert (s.r, s.psi, s.theta, s.kind) == (
            (s.r, c.psi, c.theta, c.kind)
            if c.kind in ("ball", "tapered_ball")
            else (c.r, c.psi, c.theta, c.kind)
        )


def test_with_size_diameter():
    assert parse_cutter("CUTTER/10,2").with_size(5.0).d == pytest.approx(14.0)
    assert parse_cutter("CUTTER/10,5").with_size(2.0).d == pytest.approx(4.0)
    assert parse_cutter("CUTTER/9.1633,5,0,5,0,5,60").with_size(10).d == pytest.approx(
        18.3266, abs=2e-4
    )


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("CUTTER/10,6", r"corner radius r=6 is larger than half the diameter d=10"),
        ("CUTTER/-10", r"d must be >= 0, found -10"),
        ("CUTTER/10,nan", r"r must be a finite number"),
        ("CUTTER/10,inf", r"r must be a finite number"),
        ("CUTTER/10,2,3", r"expected 1, 2 or 7 values .* found 3"),
        ("CUTTER/", r"expected 1, 2 or 7 values .* found 0"),
        ("CUTTER/ten", r"d must be a number, found 'ten'"),
        ("CUTTER/0", r"diameter must be > 0"),
        ("CUTTER/10,5,0,5,0,5,60", r"d=10 is inconsistent .* gives d=9\.1633"),
        ("CUTTER/10,2,3,5,0,0,50", r"f=5 is inconsistent .* expected f=2"),
        ("CUTTER/10,2,3,2,60,40,50", r"below 90 and sum below 90"),
        ("TLDATA/MILL,10,6,50,0,0", r"lower radius 6 is larger than half the diameter 10"),
        ("TLDATA/MILL,10,2,50,0", r"expected 5, 7 or 10 values"),
        ("TLDATA/MILL,10,2,50,0,0,4,2", r"diameter=10 is inconsistent"),
        ("TLDATA/MILL,10,2,50,0,0,3,2,-1,0,0", r"upper radius must be >= 0"),
        ("TLDATA/DRILL,10,0,50,118", r"only TLDATA/MILL"),
        ("GOTO/1,2,3", r"expected a cutter statement"),
    ],
)
def test_bad_statements_say_why(text, pattern):
    with pytest.raises(PathcheckError) as err:
        parse_cutter(text, path="job.apt", line=12)
    assert err.value.code == "cutter"
    msg = str(err.value)
    assert msg.startswith("job.apt:12: ")
    assert re.search(pattern, msg), msg


def test_inconsistent_e_is_named():
    good = _apt_line(3.0, 1.0, 10.0, 0.0)
    vals = [float(v) for v in good.split("/")[1].split(",")]
    vals[2] = 3.5
    with pytest.raises(PathcheckError, match=r"e=3\.5 is inconsistent with both d=.* and f="):
        cutter_from_apt(vals)
    assert cutter_from_apt([float(v) for v in good.split("/")[1].split(",")]).R == 3.0


def test_tldata_angles_map_to_psi_and_theta():
    c = cutter_from_tldata([9.1633, 5.0, 60.0, 5.0, 0.0])
    assert c.kind == "tapered_ball" and c.theta == pytest.approx(math.radians(5))
    assert pytest.approx(0.0, abs=1e-4) == c.R and c.H == 60.0
    d = cutter_from_tldata([20.0, 0.0, 40.0, 0.0, 45.0])
    assert d.kind == "apt" and d.psi == pytest.approx(math.radians(45)) and d.R == 10.0


def test_real_solidworks_cutters(realdata):
    folder = realdata / "amorim-solidworkscam-apt"
    seen = {}
    for f in sorted(folder.glob("*.apt")):
        for i, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            if line.startswith("CUTTER/"):
                c = parse_cutter(line, path=f, line=i)
                seen[line] = c
    assert len(seen) >= 8
    assert seen["CUTTER/14.,7.,0,7.,0,0,73."].kind == "ball"
    assert seen["CUTTER/14.,0,7.,0,0,0,84."].kind == "flat"
    assert seen["CUTTER/20.,0,10.,10.,45.,0,92."].psi == pytest.approx(math.radians(45))
    for c in seen.values():
        assert c.d == pytest.approx(2 * c.R + 2 * c.r, abs=1e-3) or c.psi or c.theta


def test_real_nx_tldata(realdata):
    folder = realdata / "mech491-nx-clsf"
    kinds = {}
    for f in sorted(folder.glob("*.txt")):
        for i, line in enumerate(f.read_text(errors="replace").splitlines(), 1):
            if line.startswith("TLDATA/MILL"):
                vals = [25.4 * float(v) for v in line.split(",")[1:]]  # files are in inches
                vals[3:5] = [v / 25.4 for v in vals[3:5]]  # angles stay degrees
                c = cutter_from_tldata(vals, path=f, line=i)
                kinds[line.split(",", 1)[1]] = c
    by = {k.split(",")[0] + "," + k.split(",")[1]: c.kind for k, c in kinds.items()}
    assert by["0.2400,0.1200"] == "ball"
    assert by["0.3750,0.0000"] == "flat"
    assert by["0.7500,0.1200"] == "bullnose"
    assert by["1.0000,0.5000"] == "ball"
    bull = next(c for k, c in kinds.items() if k.startswith("0.7500,0.1200"))
    assert pytest.approx((0.375 - 0.12) * 25.4) == bull.R and pytest.approx(4 * 25.4) == bull.H


def test_unknown_kind_rejected():
    with pytest.raises(PathcheckError, match="cutter kind must be one of"):
        Cutter("torus", 10, 2, 3)


# ---- geometry ------------------------------------------------------------------------------


def _frame(axis: np.ndarray) -> np.ndarray:
    """Rotation matrix whose rows map part vectors to the tool frame (axis -> +z)."""
    a = axis / np.linalg.norm(axis)
    t = np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(t, a)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(a, x), a])


GEOMETRY = [
    "CUTTER/10",
    "CUTTER/12,2",
    "CUTTER/10,5",
    "CUTTER/9.1633,5,0,5,0,5,60",
    _apt_line(3.0, 1.5, 10.0, 5.0, 60.0),
    "CUTTER/6.5,0,3.25,1.952797,31.,0,105.",
]


@pytest.mark.parametrize("text", GEOMETRY)
def test_tip_from_contact_touches_tangentially(text):
    """The placed cutter has cc on its surface (signed distance 0) and its outward normal
    there is -n (gradient of the signed distance by central differences)."""
    c = parse_cutter(text)
    c = Cutter(c.kind, c.d, c.r, c.R, c.psi, c.theta, 0.0)  # unbounded length
    rng = np.random.default_rng(8)
    m = 60
    axis = rng.normal(size=(m, 3)) * 0.3 + [0, 0, 1]
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    cc = rng.uniform(-20, 20, (m, 3))
    lo = math.sin(c.theta) + 0.05
    hi = math.cos(c.psi) - 0.05 if c.psi > 0 else 0.98
    nz = rng.uniform(lo, hi, m)
    ang = rng.uniform(0, 2 * math.pi, m)
    for i in range(m):
        rot = _frame(axis[i])
        h = math.sqrt(1 - nz[i] ** 2)
        n_tool = np.array([h * math.cos(ang[i]), h * math.sin(ang[i]), nz[i]])
        n = rot.T @ n_tool
        tip = c.tip_from_contact(cc[i : i + 1], n[None], axis[i])[0]
        local = rot @ (cc[i] - tip)
        assert abs(c.signed_distance(local[None])[0]) < 1e-9
        if c.r == 0.0:  # contact on a sharp edge: the cutter stays on the n side of the plane
            t1 = np.cross(n_tool, [0.3, 0.5, 0.8])
            t1 /= np.linalg.norm(t1)
            t2 = np.cross(n_tool, t1)
            for a in np.linspace(0, 2 * math.pi, 12, endpoint=False):
                step = 0.5 * (math.cos(a) * t1 + math.sin(a) * t2)
                assert c.signed_distance((local + step)[None])[0] > -1e-9
            assert c.signed_distance((local + 0.01 * n_tool)[None])[0] < 0
            continue
        eps = 1e-6
        grad = np.array(
            [
                (
                    c.signed_distance((local + eps * u)[None])[0]
                    - c.signed_distance((local - eps * u)[None])[0]
                )
                / (2 * eps)
                for u in np.eye(3)
            ]
        )
        np.testing.assert_allclose(grad, -n_tool, atol=1e-5)


def test_tip_contact_puts_the_tip_on_cc():
    drill = parse_cutter("CUTTER/6.5,0,3.25,1.952797,31.,0,105.")
    cc = np.array([[1.0, 2.0, 3.0]])
    n = np.array([[0.1, 0.0, 1.0]]) / math.hypot(0.1, 1.0)
    np.testing.assert_array_equal(drill.tip_from_contact(cc, n, [0, 0, 1.0]), cc)
    flat = parse_cutter("CUTTER/10")
    up = np.array([[0.0, 0.0, 1.0]])
    np.testing.assert_allclose(flat.tip_from_contact(cc, up, [0, 0, 1.0]), cc)
    np.testing.assert_allclose(
        flat.tip_from_contact(cc, up, [0, 0, 1.0], e=np.array([[1.0, 0, 0]])), [[6.0, 2.0, 3.0]]
    )


def test_profile_radius_known_values():
    ball = parse_cutter("CUTTER/10,5,0,5,0,0,30")
    z = np.array([-1.0, 0.0, 2.5, 5.0, 20.0, 31.0])
    np.testing.assert_allclose(
        ball.profile_radius(z), [0, 0, math.sqrt(25 - 6.25), 5, 5, 0], atol=1e-12
    )
    bull = parse_cutter("CUTTER/12,2")
    np.testing.assert_allclose(
        bull.profile_radius(np.array([0.0, 1.0, 2.0, 9.0])), [4, 4 + math.sqrt(3), 6, 6]
    )
    tb = parse_cutter("CUTTER/9.1633,5,0,5,0,5,60")
    zb = 5 - 5 * math.sin(math.radians(5))
    assert tb.profile_radius(np.array([zb + 10]))[0] == pytest.approx(
        5 * math.cos(math.radians(5)) + 10 * math.tan(math.radians(5))
    )
    drill = parse_cutter("CUTTER/6.5,0,3.25,1.952797,31.,0,105.")
    assert drill.profile_radius(np.array([1.0]))[0] == pytest.approx(1 / math.tan(math.radians(31)))


@pytest.mark.parametrize("text", GEOMETRY)
def test_signed_distance_against_dense_polyline(text):
    c = parse_cutter(text)
    H = 30.0
    c = Cutter(c.kind, c.d, c.r, c.R, c.psi, c.theta, H)
    zs = np.concatenate([np.linspace(0, c.f + c.r + 1, 6001), np.linspace(c.f, H, 2001)])
    zs = np.unique(zs)
    rad = c.profile_radius(zs)
    rad[0] = 0.0  # the tip
    poly = np.concatenate([np.column_stack([rad, zs]), [[0.0, H]]])
    rng = np.random.default_rng(6)
    rho, ang = rng.uniform(0, 0.75 * c.d, 150), rng.uniform(0, 2 * math.pi, 150)
    pts = np.column_stack([rho * np.cos(ang), rho * np.sin(ang), rng.uniform(-3, H + 3, 150)])
    got = c.signed_distance(pts)
    q = np.column_stack([np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2]])
    a, b = poly[:-1], poly[1:]
    ab = b - a
    t = np.clip(np.einsum("kij,ij->ki", q[:, None] - a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
    dist = np.linalg.norm(q[:, None] - (a + t[..., None] * ab), axis=2).min(axis=1)
    inside = (pts[:, 2] >= 0) & (pts[:, 2] <= H) & (q[:, 0] <= c.profile_radius(pts[:, 2]))
    want = np.where(inside, -dist, dist)
    np.testing.assert_allclose(got, want, atol=2e-3)
    assert inside.sum() > 10


@settings(max_examples=150, deadline=None)
@given(
    st.one_of(
        st.text(max_size=60),
        st.lists(
            st.one_of(
                st.floats(allow_nan=True, allow_infinity=True).map(repr),
                st.sampled_from(["", "x", "1e400", "-0", "5", "0.0"]),
            ),
            max_size=11,
        ).map(lambda v: "CUTTER/" + ",".join(v)),
        st.lists(st.floats(-100, 100).map(repr), max_size=11).map(
            lambda v: "TLDATA/MILL," + ",".join(v)
        ),
    )
)
def test_random_statements_raise_only_pathcheck_errors(text):
    try:
        c = parse_cutter(text)
    except PathcheckError as err:
        assert err.code == "cutter" and "\n" not in str(err)
        return
    assert c.kind in ("flat", "ball", "bullnose", "apt", "tapered_ball")
    assert c.d > 0 and c.r >= 0 and c.R >= 0 and math.isfinite(c.size)
