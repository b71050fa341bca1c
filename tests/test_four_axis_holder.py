"""Shank and holder clearance against analytic configurations."""

from __future__ import annotations

import numpy as np

from checker.four_axis.holder import check_holder

SPEC = dict(flute_length=20.0, stickout=40.0, shank_diameter=10.0, holder_diameter=40.0,
            holder_length=60.0)


def test_wall_beside_the_tool_hits_the_holder_and_the_needed_stickout_is_the_wall_top():
    # a vertical wall 15 mm from the axis, 50 mm tall: clear of the 5 mm shank, inside the
    # 20 mm holder radius from 40 mm up
    z = np.linspace(0.0, 50.0, 501)
    wall = np.stack([np.full_like(z, 15.0), np.zeros_like(z), z], axis=1)
    tips = np.array([[0.0, 0.0, 0.0], [-30.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    axes = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    result = check_holder(wall, tips, axes, **SPEC)
    assert result.hit.tolist() == [True, False, False]
    assert result.intrusion[0] == np.float64(5.0)
    assert abs(result.required_stickout[0] - 50.0) < 1e-12
    # with that stick-out the holder clears
    longer = check_holder(wall, tips[:1], axes[:1], **{**SPEC, "stickout": 50.0 + 1e-9})
    assert not longer.hit[0]


def test_shank_hit_above_the_flutes():
    post = np.array([[3.0, 0.0, 25.0], [3.0, 0.0, 10.0]])
    result = check_holder(post, np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), **SPEC)
    assert result.hit[0] and abs(result.intrusion[0] - 2.0) < 1e-12
    below_flutes = check_holder(post[1:], np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), **SPEC)
    assert not below_flutes.hit[0]
