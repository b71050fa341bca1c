"""Rotary wrap modes: a path crossing 360 degrees of B gives the expected B words in each mode,
with retract-rotate-re-enter where the word range ends."""

from __future__ import annotations

import re

import numpy as np
import pytest

from checker.errors import PathcheckError
from checker.postproc.machine import load_machine
from checker.postproc.post import PostMoves, post_program
from checker.postproc.reader import read_gcode_text
from checker.postproc.replay import part_motions
from checker.postproc.wrap import range_branches, rollover_words, unroll_rollover


def machine(wrap: str, **rotary):
    m = load_machine("linuxcnc-hmc")  # no block numbers: blocks are easy to compare
    if "b_min" in rotary or "b_max" in rotary:
        rotary["limits"] = (rotary.pop("b_min", -360.0), rotary.pop("b_max", 360.0))
    return m.with_options(rotary_axes=[{"wrap": wrap, **rotary}])


def ring(b_deg: list[float]) -> PostMoves:
    """Tips on a radius-50 ring about Y, axis radial: only the table turns."""
    b = np.asarray(b_deg, dtype=float)
    th = np.radians(b)
    tip = np.c_[-50.0 * np.sin(th), np.zeros_like(b), 50.0 * np.cos(th)]
    rapid = np.zeros(len(b), bool)
    rapid[0] = True
    return PostMoves.build(tip, b, rapid=rapid, feed=500.0)


def b_words(text: str) -> list[str]:
    """B words in program order; the approach after a tool change repeats its B (dropped)."""
    words = re.findall(r"B(-?[0-9.]+)", text)
    return [w for k, w in enumerate(words) if k == 0 or w != words[k - 1]]


def test_shortest_wraps_words_into_0_360():
    text = post_program(ring([350, 357, 364, 371]), machine("shortest"))
    assert b_words(text) == ["350.0", "357.0", "4.0", "11.0"]
    # a rollover axis never retracts: Z250 only once, the safe plane before the first move
    assert text.count("Z250.0") == 1 and text.index("Z250.0") < text.index("B350.0")


def test_signed_words_carry_the_direction():
    up = post_program(ring([350, 357, 364, 371]), machine("signed"))
    assert b_words(up) == ["350.0", "357.0", "4.0", "11.0"]
    down = post_program(ring([11, 4, 0, -3, -10]), machine("signed"))
    # first word positions the table; then every word turns the negative way, "-0." included
    assert b_words(down) == ["11.0", "-4.0", "-0.0", "-357.0", "-350.0"]


def test_0_360_retracts_rotates_and_reenters():
    text = post_program(ring([350, 357, 364, 371]), machine("0_360"))
    assert b_words(text) == ["350.0", "357.0", "360.0", "0.0", "4.0", "11.0"]
    blocks = [ln for ln in text.splitlines() if ln.startswith(("G0", "G1", "X", "Y", "Z", "B"))]
    i = next(k for k, ln in enumerate(blocks) if "B360.0" in ln)
    # cut to the range end, retract along the spindle, turn back a full turn, down, feed in
    assert blocks[i].startswith("G1") or not blocks[i].startswith("G0")
    assert blocks[i + 1] == "G0 Z250.0"
    assert blocks[i + 2] == "B0.0"
    assert blocks[i + 3] == "Z52.0"  # 2 mm re-entry clearance above Z50
    assert blocks[i + 4] == "G1 Z50.0 F250.0"  # 2 mm at 500 mm/min in G93: 1 / 0.004 min


def test_minus180_180_and_limited():
    text = post_program(ring([170, 177, 184, 191]), machine("-180_180"))
    assert b_words(text) == ["170.0", "177.0", "180.0", "-180.0", "-176.0", "-169.0"]
    # a wide limited range needs no retract: the branch is chosen to last
    wide = post_program(ring([190, 197, 204, 211]), machine("limited", b_min=-200.0, b_max=200.0))
    assert b_words(wide) == ["-170.0", "-163.0", "-156.0", "-149.0"]
    path = [-10.0, 20.0, 50.0, 80.0, 110.0, 140.0, 170.0, 199.0, 229.0, 250.0]
    crossing = post_program(ring(path), machine("limited", b_min=-200.0, b_max=200.0))
    assert b_words(crossing) == [
        *[f"{b:.1f}" for b in path[:8]],
        "200.0",
        "-160.0",
        "-131.0",
        "-110.0",
    ]


def test_limited_range_below_a_turn_is_a_travel_error():
    with pytest.raises(PathcheckError, match=r"B = 150.0000 deg cannot be reached.*\[-120, 120\]"):
        post_program(ring([0, 60, 120, 150]), machine("limited", b_min=-120.0, b_max=120.0))
    with pytest.raises(PathcheckError, match="less than a full turn"):
        post_program(ring([120, 150, 195]), machine("limited", b_min=-170.0, b_max=160.0))


@pytest.mark.parametrize("wrap", ["shortest", "signed", "0_360", "-180_180", "limited"])
def test_every_mode_reads_back_to_the_same_path(wrap):
    b = [340 + 7.5 * k for k in range(12)] + [420 - 9.0 * k for k in range(12)]
    m = machine(wrap, b_min=-400.0, b_max=400.0)
    moves = ring(b)
    read = part_motions(read_gcode_text(post_program(moves, m), "linuxcnc"), m)
    # every programmed point on the ring comes back (the re-entry point is on the ring too)
    on_ring = read.known & np.isclose(np.linalg.norm(read.tip[:, [0, 2]], axis=1), 50.0, atol=1e-4)
    expected = np.mod(np.asarray(b), 360.0)
    got = np.mod(read.b_deg[on_ring], 360.0)
    assert all(np.min(np.abs((got - e + 180) % 360 - 180)) < 1e-4 for e in expected)


def test_rollover_words_unroll_and_branches():
    words = rollover_words(np.array([0.0, 170.0, 340.0, 510.0, 350.0]), "signed", 3)
    assert np.signbit(words).tolist() == [False, False, False, False, True]
    assert np.allclose(unroll_rollover(words, "signed"), [0.0, 170.0, 340.0, 510.0, 350.0])
    assert range_branches(np.array([350.0, 370.0, 380.0]), 0.0, 360.0).tolist() == [0, -1, -1]


def test_a_cut_turning_too_far_is_retract_rotate_reenter():
    m = machine("shortest", max_turn_in_cut=45.0)
    text = post_program(ring([0, 10, 100, 110]), m)
    blocks = [ln for ln in text.splitlines() if not ln.startswith(("%", "(P"))]
    i = blocks.index("(B +90.000 deg in one cut [line 3]: retract, rotate, re-enter)")
    # from the point at B10: up to the safe plane, turn to B100, down over the end point, feed in
    assert blocks[i + 1 : i + 5] == ["G0 Z250.0", "B100.0", "Z52.0", "G1 Z50.0 F250.0"]
    assert b_words(text) == ["0.0", "10.0", "100.0", "110.0"]
