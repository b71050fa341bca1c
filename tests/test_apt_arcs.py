"""CIRCLE arcs: direction per dialect, radius, sweep, helix, turns, chordal sampling."""

from __future__ import annotations

import numpy as np
import pytest

from checker.apt import read_cl_text
from checker.errors import PathcheckError
from checker.toolpath import Arc


def apt(*lines: str) -> str:
    return "\n".join(lines) + "\n"


def test_apt_quarter_arc_is_counter_clockwise_about_its_axis():
    tp = read_cl_text(apt("CUTTER/6", "GOTO/10,0,0", "CIRCLE/0,0,0,0,0,1", "GOTO/0,10,0"))
    (arc,) = tp.arcs
    assert arc.radius == pytest.approx(10) and arc.sweep == pytest.approx(np.pi / 2)
    mid = arc.sample(0.01)
    assert np.all(mid[:, 0] >= -1e-12) and np.all(mid[:, 1] >= -1e-12)  # first quadrant
    assert tp.motion_arrays().arc.tolist() == [-1, 0]


def test_apt_clockwise_arc_with_negative_axis_goes_the_long_way_when_asked():
    # about -z, from (10,0) to (0,10) clockwise seen from +z: three quarters
    (arc,) = read_cl_text(apt("CUTTER/6", "GOTO/10,0,0", "CIRCLE/0,0,0,0,0,-1",
                              "GOTO/0,10,0")).arcs
    assert arc.sweep == pytest.approx(1.5 * np.pi)
    assert arc.sample(0.01)[:, 1].min() < -9.9  # passes below the centre


def test_nx_arc_axis_has_the_opposite_sense():
    # NX SimpleMillPlane lead-in: axis (0,0,-1), a quarter arc ending tangent to +x
    text = apt(
        "TOOL PATH/F,TOOL,T",
        "TLDATA/MILL,30,0,75,0,0",
        "FEDRAT/MMPM,250",
        "GOTO/-272.5,172.5,100",
        "CIRCLE/-265,172.5,100,0,0,-1,7.5,0.06,0.5,30,0",
        "GOTO/-265,165,100",
    )
    (arc,) = read_cl_text(text).arcs
    np.testing.assert_allclose(arc.axis, [0, 0, 1])
    assert arc.sweep == pytest.approx(np.pi / 2)


def test_full_circle_when_start_equals_end():
    (arc,) = read_cl_text(apt("CUTTER/6", "GOTO/5,0,-1", "CIRCLE/0,0,-1,0,0,1",
                              "GOTO/5,0,-1")).arcs
    assert arc.sweep == pytest.approx(2 * np.pi)
    pts = arc.sample(0.001)
    assert np.ptp(pts[:, 0]) == pytest.approx(10, abs=1e-3)


def test_helix_with_turns_moves_linearly_along_the_axis():
    arc = Arc(center=np.zeros(3), axis=np.array([0.0, 0, 1]), radius=2.0,
              start=np.array([2.0, 0, 0]), end=np.array([0.0, 2, -3]), line=1, motion=1, turns=2)
    assert arc.sweep == pytest.approx((2 + 0.25) * 2 * np.pi)
    pts = arc.sample(0.01)
    ang = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    np.testing.assert_allclose(pts[:, 2], -3 * ang / ang[-1], atol=1e-12)
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), 2.0, atol=1e-12)


@pytest.mark.parametrize("tol", [0.1, 0.01, 0.001])
def test_sampling_meets_the_chord_tolerance_and_no_more_points_than_needed(tol):
    r, sweep = 10.0, 1.5 * np.pi
    arc = Arc(np.zeros(3), np.array([0.0, 0, 1]), r, np.array([r, 0, 0]),
              np.array([0, -r, 0.0]), 1, 1)
    pts = arc.sample(tol)
    sag = r - np.linalg.norm(0.5 * (pts[1:] + pts[:-1]), axis=1)  # sagitta at chord midpoints
    assert sag.max() <= tol * (1 + 1e-9)
    n_needed = np.ceil(sweep / (2 * np.arccos(1 - tol / r)))
    assert len(pts) - 1 == n_needed


def test_nx_times_adds_full_turns():
    text = apt("CUTTER/6", "GOTO/1,0,1", "CIRCLE/0,0,0,0,0,-1,1,0.01,0.5,6,0,TIMES,3",
               "GOTO/1,0,0")
    (arc,) = read_cl_text(text.replace("CUTTER/6", "TOOL PATH/H,TOOL,T\nTLDATA/MILL,6,0,20,0,0"))\
        .arcs
    assert arc.turns == 3 and arc.sweep == pytest.approx(6 * np.pi)


def test_motion_arrays_expand_arcs_before_their_end_row():
    tp = read_cl_text(apt("CUTTER/6", "FEDRAT/100", "GOTO/10,0,0", "CIRCLE/0,0,0,0,0,1",
                          "GOTO/0,10,0", "GOTO/0,20,0"))
    m = tp.motion_arrays(arc_chord_tol=0.01)
    inner = len(tp.arcs[0].sample(0.01)) - 2
    assert len(m) == 3 + inner
    np.testing.assert_allclose(np.linalg.norm(m.tip[1 : 2 + inner], axis=1), 10, atol=1e-12)
    assert m.line.tolist() == [3] + [5] * (inner + 1) + [6]
    assert m.arc.tolist() == [-1] + [0] * (inner + 1) + [-1]
    np.testing.assert_allclose(m.tip[-1], [0, 20, 0])


def test_arc_radius_mismatch_names_the_circle_line():
    with pytest.raises(PathcheckError, match=r"<string>:3: CIRCLE/: expected the arc's start"):
        read_cl_text(apt("CUTTER/6", "GOTO/10,0,0", "CIRCLE/0,0,0,0,0,1,10", "GOTO/0,12,0"))


def test_circle_without_its_end_goto():
    with pytest.raises(PathcheckError, match=r":3: CIRCLE/: expected the arc's end GOTO, found "
                                             r"CUTTER at line 4"):
        read_cl_text(apt("CUTTER/6", "GOTO/10,0,0", "CIRCLE/0,0,0,0,0,1", "CUTTER/8",
                         "GOTO/0,10,0"))
