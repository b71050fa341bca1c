"""Multi-axis moves as the machine makes them (`checker.five_axis.machine_motion`): the pose at a
fraction of a move is the machine's forward kinematics of linearly interpolated joints
(checked against closed forms written from the machine files), and the travel bound is never
exceeded by the true motion of a tool point (dense sampling), on table-table, head-table and
head-head machines with and without tool-centre-point control."""

from __future__ import annotations

import numpy as np
import pytest

from checker.five_axis.machine_motion import MachineMotion
from checker.postproc.kinematics import Chain
from checker.postproc.machine import load_machine

MACHINES = ["linuxcnc-xyzac-trt", "fanuc-trunnion-ac", "siemens-trunnion-bc",
            "heidenhain-head-table-bc", "linuxcnc-head-head-ac", "dmc160u-millplus"]


def _motion(name: str) -> MachineMotion:
    mach = load_machine(name)
    return MachineMotion(Chain(mach), bool(mach.tcp.enabled), 1e-3, frozenset({0}))


def _random_path(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n poses near the part zero with tool axes within 50 degrees of +Z, turning by up to
    20 degrees per move (continuous words)."""
    tips = rng.uniform(-40.0, 40.0, (n, 3))
    tilt = np.radians(np.clip(np.cumsum(rng.uniform(-12, 12, n)) + 30.0, 5.0, 50.0))
    spin = np.radians(np.cumsum(rng.uniform(-15, 15, n)))
    axes = np.stack([np.sin(tilt) * np.cos(spin), np.sin(tilt) * np.sin(spin), np.cos(tilt)], 1)
    return tips, axes


@pytest.mark.parametrize("name", MACHINES)
def test_the_travel_bound_holds_for_the_true_motion_of_tool_points(name):
    rng = np.random.default_rng(7)
    motion = _motion(name)
    tips, axes = _random_path(rng, 40)
    joints = motion.joints(axes, np.arange(1, 41), None)
    path = motion.path(tips, joints)
    np.testing.assert_allclose(path.pose_at(np.arange(1, 40), np.ones(39))[0], tips[1:],
                               atol=1e-9)
    end = np.arange(1, 40)
    t = np.linspace(0.0, 1.0, 2001)
    heights = np.array([0.0, 20.0, 60.0, 120.0])  # tool points on the axis above the tip
    pts = []
    for tt in t:
        tip, ax = path.pose_at(end, np.full(end.size, tt))
        pts.append(tip[:, None] + heights[None, :, None] * ax[:, None])
    pts = np.array(pts)  # (T, M, H, 3)
    box = np.array([pts.reshape(-1, 3).min(axis=0), pts.reshape(-1, 3).max(axis=0)])
    travelled = np.linalg.norm(np.diff(pts, axis=0), axis=3).sum(axis=0).max(axis=1)
    bound = path.lengths(end, box)
    assert (travelled <= bound * (1 + 1e-9)).all()
    # and it is a bound of the right size, not a number that cannot fail
    assert np.median(bound / travelled) < 30.0
    # half a move travels at most half the bound (a stretch's bound is proportional)
    half = np.linalg.norm(np.diff(pts[: len(t) // 2 + 1], axis=0), axis=3).sum(axis=0)
    assert (half.max(axis=1) <= 0.5 * bound * (1 + 1e-9)).all()


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_pose_at_is_the_trunnion_s_closed_form_at_linear_joints():
    """fanuc-trunnion-ac without tcp: machine = Rx(A) about the line through (0, 0, -80) of
    Rz(C) about Z of the part point, the spindle along machine +Z; so at program X, A, C the
    part-frame tip is Rz(-C) (Rx(-A) (X - p) + p) with p = (0, 0, -80), its axis
    Rz(-C) Rx(-A) z."""
    rng = np.random.default_rng(3)
    motion = _motion("fanuc-trunnion-ac")
    tips, axes = _random_path(rng, 12)
    path = motion.path(tips, motion.joints(axes, np.arange(1, 13), None))
    p = np.array([0.0, 0.0, -80.0])
    end = np.arange(1, 12)
    for tt in (0.0, 0.3, 0.5, 0.9, 1.0):
        tip, ax = path.pose_at(end, np.full(end.size, tt))
        xyz = path.xyz[end - 1] + tt * (path.xyz[end] - path.xyz[end - 1])
        jt = np.radians(path.joints[end - 1] + tt * (path.joints[end] - path.joints[end - 1]))
        for k in range(end.size):
            a, c = jt[k]
            back = _rz(-c) @ (_rx(-a) @ (xyz[k] - p) + p)
            np.testing.assert_allclose(tip[k], back, atol=1e-9)
            np.testing.assert_allclose(ax[k], _rz(-c) @ _rx(-a) @ [0, 0, 1], atol=1e-12)


def test_pose_at_with_tcp_runs_the_tip_straight_and_turns_the_axis_by_the_joints():
    """linuxcnc-xyzac-trt with M428: the program carries the tip; the axis seen from the part
    is Rz(-C) Rx(-A) z at the interpolated words, which is not the normalised chord of the
    end axes."""
    rng = np.random.default_rng(5)
    motion = _motion("linuxcnc-xyzac-trt")
    tips, axes = _random_path(rng, 12)
    path = motion.path(tips, motion.joints(axes, np.arange(1, 13), None))
    end = np.arange(1, 12)
    tip, ax = path.pose_at(end, np.full(end.size, 0.5))
    np.testing.assert_allclose(tip, 0.5 * (tips[:-1] + tips[1:]), atol=1e-9)
    jt = np.radians(0.5 * (path.joints[:-1] + path.joints[1:]))
    want = np.array([_rz(-c) @ _rx(-a) @ [0, 0, 1] for a, c in jt])
    np.testing.assert_allclose(ax, want, atol=1e-12)
    chord = axes[:-1] + axes[1:]
    chord /= np.linalg.norm(chord, axis=1, keepdims=True)
    assert np.abs(ax - chord).max() > 1e-3  # the machine's motion differs from the part frame's
