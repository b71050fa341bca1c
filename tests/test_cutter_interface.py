"""The cutter as one interface (docs/MATH.md §2, §3): every module that needs the contact case
(untouchable, fillet, tip) asks `Cutter.contact_case` (the kernels' one rule, `contact_case`,
with its one slack), and agrees with it on both sides of the bounds n_z = sin(theta) and
n_z = cos(psi); outside the cutter nothing reads the family's angles or radii."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from checker import kernels
from checker.cutter import diameter_from, parse_cutter
from checker.engine.grid.family import family_bounds
from checker.engine.sizes import untouchable
from checker.flank.envelope import profile

REPO = Path(__file__).resolve().parents[1]


def _apt_text(r: float, R: float, psi_deg: float, theta_deg: float, h: float) -> str:
    """`CUTTER/d,r,e,f,alpha,beta,h` with d and f from eq. 2.5 and f = R tan(psi) + r sec(psi)."""
    psi, th = math.radians(psi_deg), math.radians(theta_deg)
    f = R * math.tan(psi) + r / math.cos(psi)
    return f"CUTTER/{diameter_from(R, r, psi, th)!r},{r},{R},{f!r},{psi_deg},{theta_deg},{h}"


CUTTERS = {
    "flat": "CUTTER/10",
    "ball": "CUTTER/10,5",
    "bullnose": "CUTTER/10,2",
    "tapered_ball": "CUTTER/9.1633,5,0,5,0,5,40",
    "drill": "CUTTER/20,0,10,5.7735,30,0,0",  # psi = 30 deg, sharp
    "apt": _apt_text(1.5, 4.5, 20.0, 7.0, 30.0),  # cone, corner and taper
}


def _cutter(name: str):
    return parse_cutter(CUTTERS[name])


def _expected(c, nz: np.ndarray) -> np.ndarray:
    """The contact case by the rule of MATH.md §3, written out independently."""
    s, co = math.sin(c.theta), math.cos(c.psi)
    out = np.full(len(nz), kernels.FILLET, dtype=np.int8)
    out[(c.psi > 0.0) & (nz > co)] = kernels.TIP
    out[(nz <= 0.0) | (nz < s - 1e-9)] = kernels.UNTOUCHABLE
    return out


def _boundary_nz(c) -> np.ndarray:
    """n_z on both sides of each bound: 0, sin(theta) (slack 1e-9), cos(psi), 1."""
    s, co = math.sin(c.theta), math.cos(c.psi)
    vals = [-1e-12, 0.0, 1e-12, 0.3, 1.0, co, np.nextafter(co, 2.0), co + 1e-12, co - 1e-12,
            s - 2e-9, s - 0.5e-9, s + 1e-12, s]
    return np.clip(np.array(vals), -1.0, 1.0)


def _rows(nz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CC points, unit normals with those z components (leaning towards +x) and unit e."""
    nx = np.sqrt(np.maximum(1.0 - nz * nz, 0.0))
    n = np.column_stack([nx, np.zeros_like(nz), nz])
    cc = np.column_stack([np.arange(len(nz), dtype=float), np.zeros(len(nz)), np.zeros(len(nz))])
    e = np.tile([1.0, 0.0, 0.0], (len(nz), 1))
    return cc, n, e


@pytest.mark.parametrize("name", list(CUTTERS))
def test_every_module_agrees_with_the_interface_on_the_contact_case(name):
    c = _cutter(name)
    nz = _boundary_nz(c)
    case = c.contact_case(nz)
    np.testing.assert_array_equal(case, _expected(c, nz))
    assert {kernels.FILLET} <= set(case.tolist())
    if c.psi > 0.0:
        assert kernels.TIP in case and kernels.FILLET in case[nz <= math.cos(c.psi)]
    cc, n, e = _rows(nz)
    # the engine's rows that take the plain scan
    np.testing.assert_array_equal(untouchable(c, n), case == kernels.UNTOUCHABLE)
    # the family bounds: tip contact fixes the axis through cc (w = 0, t = 0)
    fb = family_bounds(c, cc, n, e, np.zeros(len(nz), dtype=bool), 100.0)
    if not c.ball_family:
        tip_rows = (fb.t == 0.0) & (fb.w == 0.0).all(axis=1) & (fb.c0 == cc[:, :2]).all(axis=1)
        np.testing.assert_array_equal(tip_rows, case == kernels.TIP)
    # the tip from a contact: at cc exactly in the tip case
    tips = c.tip_from_contact(cc, n, [0.0, 0.0, 1.0])
    at_cc = (tips == cc).all(axis=1)
    touch = case != kernels.UNTOUCHABLE
    if c.psi > 0.0:
        np.testing.assert_array_equal(at_cc[touch], (case == kernels.TIP)[touch])
    # the curvature limit's closed form applies on the fillet only (R family)
    zero = np.zeros(len(nz))
    closed = c.curvature_limit(n, e, lambda: (e, np.cross(n, e)), lambda t1, t2: (zero,) * 3)
    if not c.ball_family:
        defined = np.hypot(n[:, 0], n[:, 1]) > kernels.EPS_H
        np.testing.assert_array_equal(closed.form, (case == kernels.FILLET) & defined)


@pytest.mark.parametrize("name", ["drill", "apt", "tapered_ball", "bullnose"])
def test_the_kernels_take_the_case_the_interface_names(name):
    """Sizes are 0 exactly on the untouchable side of sin(theta) - slack and positive on the
    other; above cos(psi) the APT kernel's size is the tip contact's (a cone vertex on Pcc),
    just below it the fillet's, which differs."""
    c = _cutter(name)
    prm = c.kernel_params()
    rng = np.random.default_rng(3)
    q = np.array([2.0, 5.0, 1.0]) + rng.normal(scale=0.1, size=3)  # outside the size-0 cutter
    s = math.sin(c.theta)
    for nz, want_zero in ((s - 2e-9, True), (max(s + 1e-6, 1e-6), False)):
        n = np.array([math.sqrt(1 - nz * nz), 0.0, nz])
        size = c.imaginary_size(q[None], np.zeros((1, 3)), n[None])[0]
        assert (size == 0.0) == want_zero, (nz, size)
    if c.psi > 0.0:
        co = math.cos(c.psi)
        above = np.nextafter(co, 2.0)
        n = np.array([math.sqrt(1 - above * above), 0.0, above])
        size = kernels.apt_size(*q, *n, 1.0, 0.0, True, prm)
        assert size == kernels._apt_tip_contact(*q, prm)
        below = co - 1e-9
        n = np.array([math.sqrt(1 - below * below), 0.0, below])
        size_below = kernels.apt_size(*q, *n, 1.0, 0.0, True, prm)
        assert abs(size_below - kernels._apt_tip_contact(*q, prm)) > 1e-3


@pytest.mark.parametrize("name", list(CUTTERS))
def test_profile_slope_is_the_derivative_of_the_profile_radius(name):
    """`Cutter.profile_slope` (the flank envelope's rho') against central differences of
    `Cutter.profile_radius`, away from the pieces' joints."""
    c = _cutter(name)
    z = np.linspace(0.05, 25.0, 997)
    h = 1e-6
    rho, slope = profile(c, z)
    numeric = (c.profile_radius(z + h) - c.profile_radius(z - h)) / (2 * h)
    dz = z - c.f
    joints = [-c.r * math.sin(c.theta), -c.r * math.cos(c.psi)]
    away = np.all([np.abs(dz - j) > 1e-3 for j in joints], axis=0) & (np.abs(numeric) < 1e3)
    np.testing.assert_allclose(slope[away], numeric[away], rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(rho, c.profile_radius(z))


def test_the_body_profile_is_the_core():
    """The mesh body's profile (`mesh.tool.body_profiles`) is the core's wedge: its corner is
    the corner centre (R, f) and its lower side meets the axis at r sec(psi); grown by r."""
    from checker.mesh.tool import body_profiles
    c = _cutter("apt")
    prof, nprof, rho = body_profiles(c.cores(np.array([4.5, 2.0])), 30.0)
    assert nprof.tolist() == [4, 4] and rho.tolist() == [1.5, 1.5]
    np.testing.assert_allclose(prof[0, 1], [4.5, c.f], rtol=1e-15)
    np.testing.assert_allclose(prof[:, 0, 1], 1.5 / math.cos(c.psi), rtol=1e-15)
    ball = _cutter("ball")
    _, nb, rb = body_profiles(ball.core, 30.0)
    assert nb.tolist() == [2] and rb.tolist() == [5.0]


_READS = re.compile(r"\.(psi|theta)\b|\bkind\s*(==|!=|in)\s|\b(cutter|core)\.(r|R)\b")


def test_no_module_outside_the_cutter_reads_its_angles_or_radii():
    """The engine, the contact search, the mesh code, the flank code and the kernels ask the
    cutter; none reads `.psi`, `.theta`, `cutter.r`, `core.R` or compares a `kind`."""
    files = [REPO / "checker" / "kernels.py", REPO / "checker" / "geometry" / "contact.py"]
    for sub in ("engine", "mesh", "flank"):
        files += sorted((REPO / "checker" / sub).rglob("*.py"))
    found = [f"{p.relative_to(REPO)}:{i}: {line.strip()}"
             for p in files for i, line in enumerate(p.read_text().splitlines(), 1)
             if _READS.search(line)]
    assert found == []


def test_the_read_pattern_finds_a_read():
    """The pattern above is not vacuous."""
    for line in ("x = cutter.psi", "if c.kind == 'ball':", "np.cos(core.theta)", "rr = cutter.r"):
        assert _READS.search(line), line
