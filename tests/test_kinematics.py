"""Kinematics from the chain against independent formulas: LinuxCNC's own xyzac-trt,
xyzbc-trt and xyzab-tdr inverse kinematics (transcribed from its kinematics modules), scipy
rotations composed by hand for head machines; both 5-axis solutions, the choice between them
(continuity at the pole, limits) and the singularity report."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from checker.errors import PathcheckError
from checker.postproc.kinematics import POLE_DEG, Chain
from checker.postproc.machine import Machine, load_machine

RNG = np.random.default_rng(11)


def machine(axes, tool_length=0.0, **extra) -> Machine:
    return Machine.model_validate(
        {"name": "t", "rotary_axes": axes, "head": {"tool_length": tool_length}, **extra})


def _xyzac_inverse(p, a, c, xr, yr, zr, dy, dz):
    """LinuxCNC trtfuncs.c xyzacKinematicsInverse: world pose -> joints (tool offset 0)."""
    a, c = np.radians(a), np.radians(c)
    x, y, z = (p - [xr, yr, zr]).T
    return np.c_[
        np.cos(c) * x - np.sin(c) * y + xr,
        np.sin(c) * np.cos(a) * x + np.cos(c) * np.cos(a) * y - np.sin(a) * z
        - np.cos(a) * dy + np.sin(a) * dz + dy + yr,
        np.sin(c) * np.sin(a) * x + np.cos(c) * np.sin(a) * y + np.cos(a) * z
        - np.sin(a) * dy - np.cos(a) * dz + dz + zr,
    ]


def _xyzbc_inverse(p, b, c, xr, yr, zr, dx, dz):
    """LinuxCNC trtfuncs.c xyzbcKinematicsInverse (tool offset 0)."""
    b, c = np.radians(b), np.radians(c)
    x, y, z = (p - [xr, yr, zr]).T
    dpx = -np.cos(b) * dx - np.sin(b) * dz + dx
    dpz = np.sin(b) * dx - np.cos(b) * dz + dz
    return np.c_[
        np.cos(c) * np.cos(b) * x - np.sin(c) * np.cos(b) * y + np.sin(b) * z + dpx + xr,
        np.sin(c) * x + np.cos(c) * y + yr,
        -np.cos(c) * np.sin(b) * x + np.sin(c) * np.sin(b) * y + np.cos(b) * z + dpz + zr,
    ]


def _xyzab_tdr_inverse(p, a, b):
    """LinuxCNC xyzab_tdr_kins.comp TCP inverse with all offsets 0."""
    sa, ca, sb, cb = np.sin(np.radians(a)), np.cos(np.radians(a)), np.sin(np.radians(b)), \
        np.cos(np.radians(b))
    qx, qy, qz = p.T
    return np.c_[cb * qx + sa * sb * qy - ca * sb * qz, ca * qy + sa * qz,
                 sb * qx - sa * cb * qy + ca * cb * qz]


def test_linuxcnc_trt_kinematics():
    n = 200
    p = RNG.uniform(-80, 80, (n, 3))
    a, c = RNG.uniform(-100, 50, n), RNG.uniform(-720, 720, n)
    xr, yr, zr, dy, dz = 3.0, -7.0, 12.0, 20.0, 10.0
    m = machine([
        {"name": "A", "direction": [1, 0, 0], "point": [0, yr + dy, zr + dz]},
        {"name": "C", "direction": [0, 0, 1], "point": [xr, yr, 0]},
    ])
    got = Chain(m).inverse_position(p, np.c_[a, c])
    assert np.abs(got - _xyzac_inverse(p, a, c, xr, yr, zr, dy, dz)).max() < 1e-9
    dx = 15.0
    m = machine([
        {"name": "B", "direction": [0, 1, 0], "point": [xr + dx, 0, zr + dz]},
        {"name": "C", "direction": [0, 0, 1], "point": [xr, yr, 0]},
    ])
    got = Chain(m).inverse_position(p, np.c_[a, c])
    assert np.abs(got - _xyzbc_inverse(p, a, c, xr, yr, zr, dx, dz)).max() < 1e-9
    tdr = Chain(load_machine("linuxcnc-xyzab-tdr"))
    b = RNG.uniform(-120, 120, n)
    got = tdr.inverse_position(p, np.c_[b, a], tcp=False)  # chain order: B (outer), A
    assert np.abs(got - _xyzab_tdr_inverse(p, a, b)).max() < 1e-9
    # forward undoes inverse, and the spindle seen in the part frame is the rotated +Z
    tip, axis = tdr.forward(got, np.c_[b, a])
    assert np.abs(tip - p).max() < 1e-9
    rot = Rotation.from_euler("xy", np.c_[-a, -b], degrees=True)  # machine = Ry(-b) Rx(-a) p
    assert np.abs(axis - rot.inv().apply([0, 0, 1])).max() < 1e-12


@pytest.mark.parametrize("name", ["heidenhain-head-table-bc", "linuxcnc-head-head-ac"])
def test_head_kinematics_against_composed_rotations(name):
    """Tip = xyz + pivot-rotated tool: composed by hand with scipy for the shipped heads."""
    m = load_machine(name)
    chain = Chain(m)
    n = 100
    j = np.c_[RNG.uniform(-90, 90, n), RNG.uniform(-90, 90, n)]
    xyz = RNG.uniform(-200, 200, (n, 3))
    tip, axis = chain.forward(xyz, j)
    lift = np.array([0.0, 0.0, m.head.tool_length])
    head = [i for i, a in enumerate(m.rotary_axes) if a.on == "head"]
    table = [i for i, a in enumerate(m.rotary_axes) if a.on == "table"]
    tool_tip = np.zeros((n, 3))
    tool_dir = np.tile([0.0, 0.0, 1.0], (n, 1))
    for i in reversed(head):  # spindle side first
        ax = m.rotary_axes[i]
        r = Rotation.from_rotvec(np.outer(np.radians(j[:, i]), ax.direction))
        c = np.asarray(ax.point) + lift
        tool_tip = r.apply(tool_tip - c) + c
        tool_dir = r.apply(tool_dir)
    machine_tip = xyz + tool_tip
    for i in table:  # the bed side first: undo the outer table first
        ax = m.rotary_axes[i]
        r = Rotation.from_rotvec(np.outer(np.radians(-j[:, i]), ax.direction))
        machine_tip = r.apply(machine_tip - ax.point) + ax.point
        tool_dir = r.apply(tool_dir)
    assert np.abs(tip - machine_tip).max() < 1e-9
    assert np.abs(axis - tool_dir).max() < 1e-12


@pytest.mark.parametrize("name", ["fanuc-trunnion-ac", "siemens-trunnion-bc",
                                  "heidenhain-head-table-bc", "linuxcnc-head-head-ac",
                                  "dmu70evo-840d", "haas-vf2-tr", "dmc160u-millplus"])
def test_both_solutions_make_the_axis(name):
    chain = Chain(load_machine(name))
    n = 300
    tilt = np.radians(RNG.uniform(0.5, 40, n))
    az = RNG.uniform(0, 2 * np.pi, n)
    axis = np.c_[np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)]
    sol = chain.solve(axis)
    assert sol.reach.max() < 1e-9
    for sheet in (0, 1):
        _, back = chain.forward(np.zeros((n, 3)), sol.joints[:, sheet])
        assert np.abs(back - axis).max() < 1e-9
    # two different solutions (away from the pole), the pole angle is the tilt off the free axis
    assert np.abs(sol.joints[:, 0] - sol.joints[:, 1]).max(axis=1).min() > 1e-3


def test_pole_passage_switches_solution_instead_of_flipping():
    """A straight sweep of the tool axis across the A/C trunnion's pole (through +Z): staying on
    one solution flips C by ~180 deg at the pole; the choice switches solution so no axis jumps
    and A passes through 0."""
    chain = Chain(load_machine("fanuc-trunnion-ac"))
    t = np.linspace(-1, 1, 81)
    tilt = np.radians(20 * t)  # from -20 to +20 degrees about Y: passes the pole at t = 0
    axis = np.c_[np.sin(tilt) + 1e-3, np.zeros_like(t) + 2e-3, np.cos(tilt)]
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    sol = chain.solve(axis)
    one_sheet = np.unwrap(sol.joints[:, 0], period=360.0, axis=0)
    assert abs(one_sheet[-1, 1] - one_sheet[0, 1]) > 170  # C turns half a turn on one solution
    choice = chain.choose(sol)
    assert abs(choice.joints[-1, 1] - choice.joints[0, 1]) < 10  # ... and stays put here
    steps = np.abs(np.diff(choice.joints, axis=0)).max(axis=0)
    assert steps[0] < 2  # A moves smoothly through 0
    assert np.sign(choice.joints[0, 0]) != np.sign(choice.joints[-1, 0])
    assert choice.switches.size == 1 and choice.singular.size > 0
    assert (sol.pole[choice.singular] < POLE_DEG).all()
    assert any("pole passage" in text for _, text in choice.notes)
    assert any("singular" in text for _, text in choice.notes)
    _, back = chain.forward(np.zeros((len(t), 3)), choice.joints)
    assert np.abs(back - axis).max() < 1e-9


def test_choice_keeps_the_tilt_within_its_limits():
    """B/C trunnion with B limited to [-10, 110]: axes leaning towards -X need B < 0 on one
    solution, B > 0 (C turned half a turn) on the other: the post takes the one inside."""
    m = load_machine("siemens-trunnion-bc").with_options(
        rotary_axes=[{"limits": (-10.0, 110.0)}, {}])
    chain = Chain(m)
    n = 50
    tilt = np.radians(np.linspace(30, 60, n))
    axis = np.c_[-np.sin(tilt), 0.1 * np.ones(n), np.cos(tilt)]
    joints, choice, _ = chain.words_for_axes(axis)
    assert (joints[:, 0] >= -10 - 1e-9).all() and (joints[:, 0] <= 110 + 1e-9).all()
    _, back = chain.forward(np.zeros((n, 3)), joints)
    assert np.abs(back - axis / np.linalg.norm(axis, axis=1, keepdims=True)).max() < 1e-9


def test_unreachable_axis_names_the_line():
    chain = Chain(load_machine("fanuc-hmc"))
    axis = np.array([[0.0, 0.0, 1.0], [0.0, 0.5, np.sqrt(0.75)]])
    with pytest.raises(PathcheckError, match=r"job.apt:12: tool axis .* cannot be made by "
                                             r"machine 'fanuc-hmc' \(table B\)"):
        chain.words_for_axes(axis, lines=np.array([11, 12]), path="job.apt")


def test_unreachable_five_axis_axis_is_reported():
    """The DMU's 45-degree swivel table tilts the part at most 90 deg: an axis pointing down
    cannot be made; the nearest axis it can make is 90 deg away."""
    chain = Chain(load_machine("dmu70evo-840d"))
    sol = chain.solve(np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]))
    assert sol.reach[0] == pytest.approx(90.0, abs=1e-6) and sol.reach[1] == 0.0
    with pytest.raises(PathcheckError, match=r"p.apt:3: tool axis \[0.0, 0.0, -1.0\] cannot"):
        chain.words_for_axes(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]),
                             lines=np.array([2, 3]), path="p.apt")
