"""Posting: round trip post -> read back -> part frame, feeds (G93 and the G94 rotary rule),
tool changes and flags, travel limits, atomic writes."""

from __future__ import annotations

import dataclasses
import os
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from checker.errors import PathcheckError
from checker.postproc.machine import Machine, load_machine
from checker.postproc.post import (
    PostMoves,
    machine_for_toolpath,
    moves_from_toolpath,
    post,
    post_program,
    post_toolpath,
)
from checker.postproc.reader import read_gcode_text
from checker.postproc.replay import part_motions
from checker.postproc.writer import comment, write_program
from tests.test_machines_kinds import increment_bounds

REPO = Path(__file__).resolve().parents[1]


def blade_path(n: int = 240) -> PostMoves:
    """A 4-axis zig-zag on a cylinder about Y (radius 60 mm), the axis radial (j = 0), B from
    -40 to 400 degrees (crossing 360), two tools, a rapid re-positioning, flags."""
    s = np.linspace(0.0, 1.0, n)
    b = -40.0 + 440.0 * s
    th = np.radians(b)
    radius = 60.0 + 3.0 * np.sin(25 * s)
    tip = np.c_[-radius * np.sin(th), 25.0 * np.sin(9 * s), radius * np.cos(th)]
    rapid = np.zeros(n, bool)
    rapid[[0, n // 2]] = True
    tool = np.where(np.arange(n) < 2 * n // 3, 3, 7)
    feed = np.where(np.arange(n) < n // 4, 600.0, 1200.0)
    comments = [""] * n
    comments[17] = "FLAG gouge 0.031 mm (hub)"
    comments[n // 2] = "FLAG interference\nblade+1 \u00e9"  # a new line and non-ASCII text
    return PostMoves.build(
        tip,
        b,
        rapid=rapid,
        feed=feed,
        spindle=np.where(tool == 3, 9000.0, -4000.0),
        coolant=np.where(tool == 3, 8, 7),
        tool=tool,
        comment=comments,
        line=np.arange(n) + 100,
    )


def variant(name: str, **update) -> Machine:
    """A shipped B-table machine with sections changed; ``kinematics`` (table_center,
    b_direction) and ``rotary`` (wrap, b_min, b_max, max_feed) change its B axis."""
    machine = load_machine(name)
    axis: dict = {}
    kin = update.pop("kinematics", {})
    if "table_center" in kin:
        axis["point"] = tuple(kin["table_center"])
    if "b_direction" in kin:
        axis["direction"] = (0.0, float(kin["b_direction"]), 0.0)
    rot = dict(update.pop("rotary", {}))
    if "b_min" in rot or "b_max" in rot:
        lo, hi = machine.rotary.limits
        axis["limits"] = (rot.pop("b_min", lo), rot.pop("b_max", hi))
    axis.update(rot)
    return machine.with_options(rotary_axes=[axis], **update)


def round_trip(moves: PostMoves, machine: Machine):
    posted = post(moves, machine, program_name="RT")
    read = part_motions(read_gcode_text(posted.text, machine.dialect, units=machine.units), machine)
    rows = posted.rows
    ends = rows.end & (rows.line > 0)
    at = {int(line): i for i, line in enumerate(read.line)}
    idx = np.array([at[int(line)] for line in rows.line[ends]])
    src = rows.src[ends]
    tip_err = np.linalg.norm(read.tip[idx] - moves.tip[src], axis=1)
    cos = np.clip((read.axis[idx] * moves.axis[src]).sum(axis=1), -1.0, 1.0)
    return posted, read, idx, src, tip_err, np.degrees(np.arccos(cos))


MACHINES = [
    ("fanuc-hmc", {}),
    ("linuxcnc-hmc", {}),
    (
        "fanuc-hmc",
        {
            "kinematics": {"table_center": (15.0, 0.0, -40.0), "b_direction": -1},
            "rotary": {"wrap": "0_360"},
            "feeds": {"rotary_mode": "g93"},
        },
    ),
    (
        "linuxcnc-hmc",
        {
            "kinematics": {"table_center": (-5.0, 2.0, 10.0)},
            "rotary": {"wrap": "signed"},
            "feeds": {"rotary_mode": "g94"},
        },
    ),
    ("linuxcnc-hmc", {"rotary": {"wrap": "-180_180"}}),
]


@pytest.mark.parametrize(("name", "update"), MACHINES)
def test_round_trip_synthetic(name, update):
    moves = blade_path()
    machine = variant(name, **update)
    posted, read, idx, src, tip_err, axis_err = round_trip(moves, machine)
    # every source move is written (none dropped) and comes back within the increments' bounds
    assert np.array_equal(np.unique(src), np.arange(len(moves)))
    tip_bound, axis_bound = increment_bounds(machine, read, idx)
    assert tip_err.max() < tip_bound
    assert axis_err.max() < axis_bound
    # the feed read back is the programmed feed (tip speed relative to the part)
    feed = read.block_feed()  # the tip speed averaged over each block
    feed_rows = ~moves.rapid[src] & np.isfinite(feed[idx])
    assert feed_rows.sum() > len(moves) // 2
    assert np.allclose(feed[idx][feed_rows], moves.feed[src][feed_rows], rtol=2e-3)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    name=st.sampled_from(["fanuc-hmc", "linuxcnc-hmc"]),
    wrap=st.sampled_from(["shortest", "signed", "0_360", "-180_180", "limited"]),
    direction=st.sampled_from([1, -1]),
)
def test_round_trip_random_paths(seed, name, wrap, direction):
    """Random 4-axis paths (B steps up to 40 deg, rapids, tool changes) on random machines."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    b = rng.uniform(-720, 720) + np.cumsum(rng.uniform(-40, 40, n))
    tip = rng.uniform(-120, 120, (n, 3))
    rapid = rng.random(n) < 0.2
    rapid[0] = True
    machine = variant(
        name,
        kinematics={"table_center": tuple(rng.uniform(-50, 50, 3)), "b_direction": direction},
        rotary={"wrap": wrap, "b_min": -400.0, "b_max": 400.0},
        feeds={"rotary_mode": rng.choice(["g93", "g94"])},
    )
    tool = np.where(np.arange(n) < n // 2, 1, int(rng.integers(1, 4)))
    moves = PostMoves.build(tip, b, rapid=rapid, feed=rng.uniform(50, 3000), tool=tool)
    _, read, idx, src, tip_err, axis_err = round_trip(moves, machine)
    assert np.array_equal(np.unique(src), np.arange(n))
    tip_bound, axis_bound = increment_bounds(machine, read, idx)
    assert tip_err.max() < tip_bound and axis_err.max() < axis_bound
    assert np.all(read.known[idx])


def test_round_trip_inch_program():
    # the job is in inches: the program is written in inches (G20) on a mm machine definition
    moves = dataclasses.replace(blade_path(), units="inch")
    posted, read, idx, src, tip_err, axis_err = round_trip(moves, load_machine("linuxcnc-hmc"))
    assert "G20" in posted.text and "G21" not in posted.text
    assert "Z9.84252" in posted.text  # safe_z 250 mm
    assert tip_err.max() < 1e-3  # 5 decimals of an inch
    assert axis_err.max() < 1e-4


def _sample_jobs() -> list[Path]:
    """The 4-axis and 3-axis sample jobs (the 5-axis ones have their own round trips:
    tests/test_impeller_sample.py, the impeller and the flank pass)."""
    return sorted(p for p in (REPO / "samples").glob("*/*.apt")
                  if p.parent.name not in ("impeller", "flank"))


@pytest.mark.parametrize("dialect_machine", ["fanuc-hmc", "linuxcnc-hmc"])
def test_round_trip_sample_jobs(dialect_machine):
    jobs = _sample_jobs()
    assert jobs, "the bundled samples/*/*.apt are missing"
    from checker.apt import read_cl

    machine = load_machine(dialect_machine)
    for job in jobs:
        moves = moves_from_toolpath(read_cl(job))
        _, read, idx, src, tip_err, axis_err = round_trip(moves, machine)
        assert np.array_equal(np.unique(src), np.arange(len(moves))), job
        tip_bound, axis_bound = increment_bounds(machine, read, idx)
        assert tip_err.max() < tip_bound, job
        assert axis_err.max() < axis_bound, job


def test_moves_from_toolpath_recomputes_the_tip_at_the_chosen_b():
    from checker.apt import read_cl_text
    from checker.cutter import parse_cutter

    text = (
        "PARTNO/T\nUNITS/MM\nMULTAX\nCUTTER/6,3\nLOADTL/4\nSPINDL/9000,RPM,CLW\nRAPID\n"
        "GOTO/0,0,100,0,0,1\nFEDRAT/500,MMPM\nGOTO/0,0,60,0,0,1\nGOTO/10,0,60,-0.6,0,0.8\n"
        "GOTO/20,5,58,-0.6,0,0.8\nEND\n"
    )
    tp = read_cl_text(text)
    original = moves_from_toolpath(tp)
    # b = atan2(-i, k) (docs/MATH.md §1): the axis (-0.6, 0, 0.8) gives atan2(3, 4)
    b_cl = np.degrees(np.arctan2(0.6, 0.8))
    assert original.b_deg == pytest.approx([0, 0, b_cl, b_cl], abs=1e-9)
    assert original.tool.tolist() == [4, 4, 4, 4] and original.spindle[0] == 9000.0
    assert original.rapid.tolist() == [True, False, False, False] and original.feed[1] == 500.0
    # a ball D6: contact points and normals, then the B chosen by the checker (+10 degrees)
    r = 3.0
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [-0.28, 0.0, 0.96], [-0.6, 0.0, 0.8]])
    centre = original.tip + r * original.axis
    cc = centre - r * normals
    b_new = original.b_deg + 10.0
    moves = moves_from_toolpath(
        tp, b_deg=b_new, cc=cc, normals=normals, cutter=parse_cutter("CUTTER/6,3")
    )
    axis = np.c_[-np.sin(np.radians(b_new)), np.zeros(4), np.cos(np.radians(b_new))]
    assert np.allclose(moves.axis, axis, atol=1e-12)
    # the ball centre stays on the contact's offset point; the tip moves with the axis
    assert np.allclose(moves.tip, cc + r * normals - r * axis, atol=1e-9)
    assert np.allclose(moves.tip + r * moves.axis, centre, atol=1e-9)
    assert moves.source == tp.path and moves.line.tolist() == original.line.tolist()


def test_cl_arcs_are_posted_as_chords_within_tolerance():
    from checker.apt import read_cl_text

    text = (
        "PARTNO/ARC\nUNITS/MM\nCUTTER/6\nLOADTL/1\nRAPID\nGOTO/10,0,20\nFEDRAT/300,MMPM\n"
        "GOTO/10,0,10\nCIRCLE/0,0,10,0,0,1,10\nGOTO/0,10,10\nEND\n"
    )
    moves = moves_from_toolpath(read_cl_text(text))
    machine = load_machine("linuxcnc-hmc")
    read = part_motions(read_gcode_text(post_program(moves, machine), "linuxcnc"), machine)
    on_arc = read.known & np.isclose(read.tip[:, 2], 10.0) & (read.tip[:, 1] > 1e-6)
    r = np.hypot(read.tip[on_arc, 0], read.tip[on_arc, 1])
    assert on_arc.sum() > 10  # a quarter circle of radius 10 at 0.01 mm sagitta: chords
    assert np.all(r <= 10.0 + 1e-4) and np.all(r >= 10.0 - 0.01 - 1e-4)
    assert np.allclose(read.tip[on_arc][-1], [0.0, 10.0, 10.0], atol=1e-4)


def test_five_axis_cl_is_not_posted_for_a_b_table():
    from checker.apt import read_cl_text

    text = "PARTNO/X\nMULTAX\nCUTTER/6\nGOTO/0,0,50,0,0,1\nGOTO/5,0,50,0,0.6,0.8\nEND\n"
    with pytest.raises(PathcheckError, match=r"job5.apt:5: not a 4-axis path about Y: tool axis"):
        moves_from_toolpath(read_cl_text(text, path="job5.apt"))


def test_post_toolpath_writes_the_job_program(tmp_path):
    job = REPO / "samples" / "compressor" / "compressor_small.apt"
    from checker.apt import read_cl

    tp = read_cl(job)
    moves = moves_from_toolpath(tp)
    b = moves.b_deg + 5.0  # as if the checker had chosen other angles
    flags = [""] * len(moves)
    flags[3] = "FLAG interference 0.2 mm"
    out = post_toolpath(tp, tmp_path / "job.nc", b_deg=b, comments=flags)
    text = out.read_text()
    assert text.splitlines()[1] == "O1000 (COMPRESSOR_SMALL)"  # PPRINT/MACHINE fanuc-hmc
    assert "(FLAG interference 0.2 mm)" in text
    machine = load_machine("fanuc-hmc")
    read = part_motions(read_gcode_text(text, "fanuc"), machine)
    cut = read.known & ~read.rapid
    # every chosen B of a cut comes back from the program (angles modulo 360) to the increment
    diff = (read.b_deg[cut][None, :] - b[~moves.rapid][:, None] + 180.0) % 360.0 - 180.0
    assert np.abs(diff).min(axis=1).max() <= machine.format.rotary_increment / 2 + 1e-9
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job.nc"]


def test_machine_for_toolpath():
    from checker.apt import read_cl_text

    named = read_cl_text("PARTNO/X\nPPRINT/MACHINE linuxcnc-hmc\nCUTTER/6\nGOTO/0,0,0\nEND\n")
    plain = read_cl_text("PARTNO/X\nCUTTER/6\nGOTO/0,0,0\nEND\n")
    assert machine_for_toolpath(named).name == "linuxcnc-hmc"
    assert machine_for_toolpath(plain).name == "fanuc-hmc"
    assert machine_for_toolpath(named, "fanuc-hmc").name == "fanuc-hmc"
    with pytest.raises(PathcheckError, match="unknown machine 'mill9'"):
        machine_for_toolpath(read_cl_text("PPRINT/MACHINE mill9\nCUTTER/6\nGOTO/0,0,0\nEND\n"))


def _blocks(text: str, rollover: bool) -> list[dict[str, float]]:
    """Modal X Y Z B F and G of every motion block, read with plain regular expressions; B as
    the continuous table position."""
    state = {"X": np.nan, "Y": np.nan, "Z": np.nan, "B": 0.0, "F": np.nan, "G": np.nan}
    out = []
    for line in text.splitlines():
        code = re.sub(r"\(.*?\)", "", line)
        words = dict(re.findall(r"([A-Z])(-?[0-9.]+)", code))
        if "B" in words and rollover:  # the table takes the shorter way
            step = (float(words.pop("B")) - state["B"] + 180.0) % 360.0 - 180.0
            state["B"] += step
        state.update({k: float(v) for k, v in words.items() if k in state})
        if any(k in words for k in "XYZB"):
            out.append({**state, "F_here": "F" in words, "line": line})
    return out


def _tip_length(machine: Machine, a: dict, b: dict, steps: int = 400) -> float:
    """Tip path length relative to the part by dense sampling (scipy rotations)."""
    t = np.linspace(0.0, 1.0, steps + 1)[:, None]
    xyz = np.array([a["X"], a["Y"], a["Z"]]) * (1 - t) + np.array([b["X"], b["Y"], b["Z"]]) * t
    bw = a["B"] * (1 - t[:, 0]) + b["B"] * t[:, 0]
    c = np.array(machine.kinematics.table_center)
    tips = (
        Rotation.from_euler("y", machine.kinematics.b_direction * bw[:, None], degrees=True)
        .inv()
        .apply(xyz - c)
    )
    return float(np.linalg.norm(np.diff(tips, axis=0), axis=1).sum())


def _feed_blocks(machine: Machine, moves: PostMoves):
    blocks = _blocks(post_program(moves, machine), machine.rotary.wrap == "shortest")
    pairs = [
        (a, b)
        for a, b in zip(blocks, blocks[1:], strict=False)
        if b["G"] == 1 and np.isfinite(a["Z"])
    ]
    assert len(pairs) > 20
    return pairs


def _uniform_path() -> PostMoves:
    n = 60
    b = np.linspace(-30.0, 30.0, n)
    th = np.radians(b)
    tip = np.c_[-70.0 * np.sin(th), np.linspace(-10.0, 10.0, n), 70.0 * np.cos(th)]
    rapid = np.zeros(n, bool)
    rapid[0] = True
    return PostMoves.build(tip, b, rapid=rapid, feed=900.0, tool=1)


def test_g93_feed_is_inverse_block_time():
    machine = load_machine("linuxcnc-hmc")
    assert machine.feeds.rotary_mode == "g93"
    for a, b in _feed_blocks(machine, _uniform_path()):
        assert b["F_here"], b["line"]  # G93: F on every feed block
        minutes = _tip_length(machine, a, b) / 900.0
        assert b["F"] == pytest.approx(1.0 / minutes, rel=2e-4), b["line"]


def test_g94_rotary_rule_fanuc():
    """Fanuc rule: the control runs sqrt(dX^2+dY^2+dZ^2+dB^2) (degrees as mm) at F; the post
    scales F so that time equals the tip path length over the programmed feed."""
    machine = load_machine("fanuc-hmc")
    for a, b in _feed_blocks(machine, _uniform_path()):
        d = np.sqrt(sum((b[k] - a[k]) ** 2 for k in "XYZB"))
        control_minutes = d / b["F"]
        assert control_minutes == pytest.approx(_tip_length(machine, a, b) / 900.0, rel=2e-3), b[
            "line"
        ]


def test_g94_rotary_rule_linuxcnc_and_plain_moves():
    machine = variant("linuxcnc-hmc", feeds={"rotary_mode": "g94"})
    for a, b in _feed_blocks(machine, _uniform_path()):
        d = np.sqrt(sum((b[k] - a[k]) ** 2 for k in "XYZ"))
        assert d / b["F"] == pytest.approx(_tip_length(machine, a, b) / 900.0, rel=2e-3), b["line"]
    # without B motion F is the programmed feed itself
    n = 10
    flat = PostMoves.build(
        np.c_[np.arange(n) * 5.0, np.zeros(n), np.full(n, 20.0)], 15.0, feed=750.0, tool=1
    )
    text = post_program(flat, load_machine("fanuc-hmc"))
    assert set(re.findall(r"F([0-9.]+)", text)) == {"750.0"}


def test_rotary_speed_limit_stretches_block_time():
    machine = variant("linuxcnc-hmc", rotary={"max_feed": 100.0})
    n = 3
    tip = np.zeros((n, 3))  # the tip on the B axis: only the table turns, 20 deg per block
    moves = PostMoves.build(tip, [0.0, 20.0, 40.0], rapid=[True, False, False], feed=500.0, tool=1)
    f = [float(v) for v in re.findall(r"B-?[0-9.]+ F([0-9.]+)", post_program(moves, machine))]
    assert f == [pytest.approx(5.0), pytest.approx(5.0)]  # 20 deg at 100 deg/min = 0.2 min
    # G94: the Fanuc rule inflates F where B turns; it never exceeds the machine's maximum
    slow = variant("fanuc-hmc", feeds={"max_linear": 1000.0})
    words = [float(v) for v in re.findall(r"F([0-9.]+)", post_program(blade_path(), slow))]
    assert max(words) <= 1000.0 and max(words) > 990.0


def test_program_structure_tool_changes_flags():
    moves = blade_path()
    text = post_program(moves, load_machine("fanuc-hmc"), program_name="BLADE")
    lines = text.splitlines()
    assert lines[0] == "%" and lines[-1] == "%" and lines[1] == "O1000 (BLADE)"
    assert "(FLAG gouge 0.031 mm [hub])" in lines and "(FLAG interference blade+1 ?)" in lines
    posted = post(moves, load_machine("fanuc-hmc"))
    for k, flag in enumerate(moves.comment):
        if flag:  # the flag sits right before the blocks of its move, after the previous move
            at = lines.index(comment(flag)) + 1
            own = posted.rows.line[(posted.rows.src == k) & (posted.rows.line > 0)]
            before = posted.rows.line[(posted.rows.src == k - 1) & (posted.rows.line > 0)]
            assert before.max() < at < own.min()
    assert [ln.split(" ", 1)[1] for ln in lines if "M06" in ln] == ["T03 M06", "T07 M06"]
    assert any(ln.endswith("S9000 M03") for ln in lines) and any(
        ln.endswith("S4000 M04") for ln in lines
    )
    assert any(ln.endswith("M08") for ln in lines) and any(ln.endswith("M07") for ln in lines)
    assert sum("G43" in ln for ln in lines) == 2 and "H07" in text
    numbers = [int(m) for m in re.findall(r"^N(\d+) ", text, flags=re.M)]
    assert numbers == list(range(10, 10 * len(numbers) + 1, 10))
    linux = post_program(moves, load_machine("linuxcnc-hmc"))
    assert "T7 M6" in linux and not re.search(r"^N\d", linux, flags=re.M)


def test_travel_limit_names_the_block():
    moves = _uniform_path()
    # the path runs at Z 70
    machine = variant("fanuc-hmc", travel={"z": (-300.0, 60.0)}, program={"safe_z": 50.0})
    with pytest.raises(PathcheckError) as err:
        post_program(moves, machine)
    msg = str(err.value)
    assert re.search(r"block 'N\d+ G00 G43 .*Z70\.0", msg), msg
    assert "moves Z to 70.0000 mm" in msg and "[-300, 60]" in msg and ":1:" not in msg


def test_bad_moves_are_errors():
    machine = load_machine()
    with pytest.raises(PathcheckError, match="feed move without a feed rate"):
        post_program(PostMoves.build(np.zeros((2, 3)), 0.0), machine)
    good = _uniform_path()
    bad = PostMoves(**{**good.__dict__, "axis": np.tile([0.0, 0.0, 1.0], (len(good), 1))})
    with pytest.raises(PathcheckError, match="does not match B"):
        post_program(bad, machine)


def test_write_program_is_atomic(tmp_path, monkeypatch):
    target = tmp_path / "job.nc"
    write_program("OLD\n", target)
    assert target.read_text() == "OLD\n"

    def fail(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(PathcheckError, match="No space left"):
        write_program("NEW PROGRAM\n", target)
    assert target.read_text() == "OLD\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job.nc"]


def test_block_numbers_wrap_at_the_machines_maximum():
    """fanuc-hmc numbers blocks N10, N20, ... up to N99990 (its block_max 99999), then again
    from N10: a program of 10,500 moves read back has every move, and its N numbers rise by 10
    and wrap once."""
    n = 10_500
    tip = np.c_[np.linspace(0.0, 100.0, n), np.zeros(n), np.full(n, 20.0)]
    rapid = np.zeros(n, bool)
    rapid[0] = True
    machine = load_machine("fanuc-hmc")
    assert (machine.format.block_max, machine.format.block_increment) == (99999, 10)
    text = post_program(PostMoves.build(tip, 0.0, rapid=rapid, feed=500.0, tool=1), machine)
    read = read_gcode_text(text, "fanuc")
    assert np.isfinite(read.xyz[:, 0]).sum() >= n
    numbers = np.array([int(v) for v in re.findall(r"^N(\d+) ", text, flags=re.M)])
    wraps = np.flatnonzero(np.diff(numbers) != 10)
    assert len(numbers) > 10_000 and wraps.tolist() == [9998]
    assert numbers[9998] == 99990 and numbers[9999] == 10
    assert numbers.max() <= 99999
