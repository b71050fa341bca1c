"""Intermediate poses follow the machine's linear X, Y, Z, B interpolation."""

from __future__ import annotations

import numpy as np

from checker.four_axis.axes import axis_for_b, rotate_about_y
from checker.four_axis.poses import intermediate_poses


def test_pure_rotation_keeps_the_machine_tip_fixed_and_sweeps_the_part_frame_tip():
    centre = np.array([0.0, 0.0, 0.0])
    tip = np.array([[0.0, 0.0, 100.0]])
    # same machine position at both ends: the part-frame tip at B=0 and at B=30
    tips = np.vstack([tip, rotate_about_y(tip, np.array([-30.0]), centre)])
    poses = intermediate_poses(tips, np.array([0.0, 30.0]), centre, max_chord=1.0, max_db=1.0)
    assert len(poses.t) == 29
    np.testing.assert_allclose(poses.b, np.arange(1.0, 30.0))
    machine = rotate_about_y(poses.tip, poses.b, centre)
    np.testing.assert_allclose(machine, np.repeat(tip, 29, axis=0), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(poses.tip, axis=1), 100.0)
    np.testing.assert_allclose(poses.axis, axis_for_b(poses.b))


def test_linear_move_is_split_by_chord_and_stays_on_the_segment():
    centre = np.array([5.0, 0.0, -20.0])
    tips = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 3.0, 0.0]])
    poses = intermediate_poses(tips, np.zeros(3), centre, max_chord=0.5, max_db=1.0)
    assert np.count_nonzero(poses.move == 0) == 19 and np.count_nonzero(poses.move == 1) == 5
    seg = poses.move == 0
    np.testing.assert_allclose(poses.tip[seg, 0], 10.0 * poses.t[seg])
    np.testing.assert_allclose(poses.tip[seg, 1:], 0.0, atol=1e-12)
    only_second = intermediate_poses(tips, np.zeros(3), centre, max_chord=0.5, max_db=1.0,
                                     moves=np.array([1]))
    assert set(only_second.move.tolist()) == {1}
