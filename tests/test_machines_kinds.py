"""Every machine kind, with and without tool-centre-point control, in every dialect: post ->
read -> part frame within what the control's increments allow (`increment_bounds`); a 4-axis
job gives the same part-frame motion on the vertical A machine and the horizontal B machine;
feed modes read as the control means them; the pole passage reported in the program."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from checker.postproc.dialects import DIALECTS
from checker.postproc.kinematics import Chain, rotate
from checker.postproc.machine import Machine, load_machine
from checker.postproc.post import PostMoves, moves_from_toolpath, post
from checker.postproc.reader import read_gcode_text
from checker.postproc.replay import part_motions

REPO = Path(__file__).resolve().parents[1]
KINDS = {
    "fanuc-hmc": "horizontal B table",
    "fanuc-vmc-a": "vertical A table",
    "fanuc-trunnion-ac": "table-table A/C",
    "siemens-trunnion-bc": "table-table B/C",
    "heidenhain-head-table-bc": "head-table B/C",
    "linuxcnc-head-head-ac": "head-head C/A",
}
RESULTS: list[tuple] = []


def five_axis_path(n: int = 120) -> PostMoves:
    """Tool axes tilting 5..55 deg off +Z while the azimuth turns 400 deg (close to the pole
    three times), a spiral of tips, a tool change half way."""
    s = np.linspace(0, 1, n)
    tilt = np.radians(5 + 50 * np.abs(np.sin(3 * np.pi * s)))
    az = np.radians(-60 + 400 * s)
    axis = np.c_[np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)]
    tip = np.c_[40 * np.cos(az) * s, 40 * np.sin(az) * s, 10 * np.sin(5 * s)]
    rapid = np.zeros(n, bool)
    rapid[[0, n // 2]] = True
    tool = np.where(np.arange(n) < n // 2, 1, 2)
    return PostMoves.build(tip, axis=axis, rapid=rapid, feed=np.where(s < 0.7, 800.0, 1500.0),
                           tool=tool, spindle=6000.0)


def four_axis_path(m: Machine, n: int = 80) -> PostMoves:
    """Axes perpendicular to the machine's one rotary axis (in the part frame), turning 300 deg,
    tips on a cylinder of radius 60 about it."""
    chain = Chain(m)
    u = chain.rot.T @ chain.direction[0]
    z = np.array([0.0, 0.0, 1.0]) - u * u[2]
    z /= np.linalg.norm(z)
    s = np.linspace(0, 1, n)
    axis = rotate(np.tile(z, (n, 1)), u, -(-30 + 300 * s))
    tip = 60 * axis + np.outer(20 * s, u)
    rapid = np.zeros(n, bool)
    rapid[0] = True
    return PostMoves.build(tip, axis=axis, rapid=rapid, feed=600.0, tool=3)


def round_trip(moves: PostMoves, machine: Machine):
    posted = post(moves, machine, program_name="RT")
    read = part_motions(read_gcode_text(posted.text, machine.dialect, units=machine.units),
                        machine)
    rows = posted.rows
    ends = rows.end & (rows.line > 0)
    at = {int(line): i for i, line in enumerate(read.line)}
    idx = np.array([at[int(line)] for line in rows.line[ends]])
    src = rows.src[ends]
    tip_err = np.linalg.norm(read.tip[idx] - moves.tip[src], axis=1)
    cos = np.clip((read.axis[idx] * moves.axis[src]).sum(axis=1), -1.0, 1.0)
    return posted, read, idx, src, tip_err, np.degrees(np.arccos(cos))


def increment_bounds(machine: Machine, read, idx: np.ndarray) -> tuple[float, float]:
    """The largest post -> read error the machine's increments allow at the rows ``idx`` of
    ``read`` (`part_motions`): tip mm (each X Y Z word within half a linear increment, plus how
    far half a rotary increment of each axis moves the tip, by the chain's forward kinematics)
    and tool axis degrees (half a rotary increment per axis, plus what arccos resolves near 0)."""
    fmt = machine.format
    linear = fmt.inch_increment * 25.4 if machine.units == "inch" else fmt.linear_increment
    half = fmt.rotary_increment / 2
    chain = Chain(machine)
    xyz, joints, tcp = read.xyz[idx], read.joints[idx], read.tcp[idx]
    tip0, _ = chain.forward(xyz, joints, tcp)
    turned = np.zeros(len(idx))
    for i in range(chain.k):
        tip1, _ = chain.forward(xyz, joints + half * np.eye(chain.k)[i], tcp)
        turned += np.linalg.norm(tip1 - tip0, axis=1)
    arccos = np.degrees(np.sqrt(4 * np.finfo(float).eps))
    tip = np.sqrt(3) * linear / 2 + float(turned.max(initial=0.0)) + 1e-9
    return tip, chain.k * half + arccos


def _check_feeds(moves, machine, read, idx, src):
    """The tip speed read back (averaged over each block) is the programmed feed, except where
    an axis would pass its maximum speed: no piece of any block drives an axis beyond its
    maximum, and in the slowed blocks the fastest axis runs at (close to) its maximum."""
    from checker.postproc.checks import machine_xyz

    feed = read.block_feed()
    rows = ~moves.rapid[src] & np.isfinite(feed[idx])
    assert rows.sum() > len(moves) // 2
    got, want = feed[idx][rows], moves.feed[src][rows]
    assert (got <= want * (1 + 2e-3)).all()
    slow = got < want * (1 - 2e-3)
    assert slow.mean() < 0.5
    with np.errstate(invalid="ignore", divide="ignore"):
        rot = np.abs(np.diff(read.joints, axis=0, prepend=read.joints[:1])) / read.minutes[:, None]
        rot = (rot / np.array([a.max_feed for a in machine.rotary_axes])).max(axis=1)
        xyz = machine_xyz(read, machine)
        lin = np.linalg.norm(np.diff(xyz, axis=0, prepend=xyz[:1]), axis=1) / read.minutes
        load = np.maximum(rot, lin / machine.feeds.max_linear)
    cutting = ~read.rapid & np.isfinite(load)
    assert load[cutting].max() < 1 + 5e-3  # no axis beyond its maximum, anywhere
    for block in read.block[idx[rows][slow]]:
        assert load[read.block == block].max() > 0.95


@pytest.mark.parametrize("tcp", [False, True], ids=["no-tcp", "tcp"])
@pytest.mark.parametrize("dialect", list(DIALECTS))
@pytest.mark.parametrize("name", list(KINDS))
def test_round_trip_every_kind_dialect_and_tcp(name, dialect, tcp):
    machine = load_machine(name).with_dialect(dialect).with_options(tcp={"enabled": tcp})
    moves = five_axis_path() if len(machine.rotary_axes) == 2 else four_axis_path(machine)
    posted, read, idx, src, tip_err, axis_err = round_trip(moves, machine)
    bounds = increment_bounds(machine, read, idx)
    RESULTS.append((KINDS[name], dialect, tcp, tip_err.max(), axis_err.max(), *bounds))
    assert np.array_equal(np.unique(src), np.arange(len(moves)))  # no move dropped
    assert tip_err.max() < bounds[0] and axis_err.max() < bounds[1]
    _check_feeds(moves, machine, read, idx, src)
    text = posted.text
    dia = DIALECTS[dialect]
    if tcp:  # the control's own words switch it on and off
        assert dia.tcp_on_block.split()[0] in text and dia.tcp_off_block in text
    letters = set(re.findall(r"(?<![A-Z0-9.])([ABC])-?[0-9.]+", text))
    assert letters == {a.name for a in machine.rotary_axes}


def test_round_trip_table():
    """Prints the worst errors of the matrix above (run after it)."""
    if not RESULTS:
        pytest.skip("the round-trip matrix did not run")
    print(f"\n{'kind':20s} {'dialect':10s} {'tcp':5s} {'tip mm':>9s} {'bound':>9s} "
          f"{'axis deg':>9s} {'bound':>9s}")
    for kind, dialect, tcp, tip, ax, tip_bound, ax_bound in RESULTS:
        print(f"{kind:20s} {dialect:10s} {tcp!s:5s} {tip:9.2e} {tip_bound:9.2e} {ax:9.2e} "
              f"{ax_bound:9.2e}")
    assert all(r[3] < r[5] and r[4] < r[6] for r in RESULTS)


def test_four_axis_job_same_motion_on_vertical_a_and_horizontal_b():
    """The compressor sample (a 4-axis job about the part's Y) posted for the horizontal B
    machine and for the vertical A machine (the part turned so its Y lies along machine X): the
    programs differ (B words vs A words) and read back to the same part-frame motion."""
    from checker.apt import read_cl

    job = REPO / "samples/compressor/compressor_small_d12.apt"
    moves = moves_from_toolpath(read_cl(job))
    hmc = load_machine("fanuc-hmc")
    vmc = load_machine("fanuc-vmc-a").with_options(
        setup={"rotation": ((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0))})
    p_b, read_b, idx_b, src_b, tip_b, ax_b = round_trip(moves, hmc)
    p_a, read_a, idx_a, src_a, tip_a, ax_a = round_trip(moves, vmc)
    assert " B" in p_b.text and not re.search(r" A-?\d", p_b.text)
    assert re.search(r" A-?\d", p_a.text) and not re.search(r" B-?\d", p_a.text)
    bound_b, bound_a = increment_bounds(hmc, read_b, idx_b), increment_bounds(vmc, read_a, idx_a)
    assert tip_b.max() < bound_b[0] and tip_a.max() < bound_a[0]
    assert ax_b.max() < bound_b[1] and ax_a.max() < bound_a[1]
    end_b = {int(s): i for s, i in zip(src_b, idx_b, strict=True)}
    end_a = {int(s): i for s, i in zip(src_a, idx_a, strict=True)}
    common = sorted(set(end_b) & set(end_a))
    assert len(common) == len(moves)
    ib = np.array([end_b[k] for k in common])
    ia = np.array([end_a[k] for k in common])
    assert np.abs(read_b.tip[ib] - read_a.tip[ia]).max() < bound_b[0] + bound_a[0]
    assert np.abs(read_b.axis[ib] - read_a.axis[ia]).max() < np.radians(bound_b[1] + bound_a[1])
    fb, fa = read_b.block_feed()[ib], read_a.block_feed()[ia]
    ok = np.isfinite(fb) & np.isfinite(fa)
    assert ok.sum() > len(moves) // 2 and np.allclose(fb[ok], fa[ok], rtol=2e-3)
    # the table angle is the same turn: A on the vertical machine = B on the horizontal one
    wa = read_a.joints[ia, 0]
    wb = read_b.joints[ib, 0]
    assert np.abs((wa - wb + 180) % 360 - 180).max() <= hmc.format.rotary_increment + 1e-9
    print(f"\n4-axis job {job.name}: {len(moves)} moves, B vs A max tip difference "
          f"{np.abs(read_b.tip[ib] - read_a.tip[ia]).max():.2e} mm")


@pytest.mark.parametrize("beside", [0.0, 1e-3], ids=["through-pole", "beside-pole"])
def test_pole_passage_is_reported_in_the_program(beside):
    """A sweep of the tool axis across the A/C trunnion's pole. Through the pole the post takes
    the other solution there (A passes 0, C stays); 0.06 deg beside it C must swing half a turn
    (no solution avoids it): the post reports the singular passage and cuts it as retract,
    rotate, re-enter. Both say so in the program and in `PostedProgram.notes`, and read back."""
    n = 81
    t = np.linspace(-1, 1, n)
    tilt = np.radians(20 * t)
    axis = np.c_[np.sin(tilt), np.full(n, beside), np.cos(tilt)]
    tip = np.c_[50 * t, np.zeros(n), np.zeros(n)]
    rapid = np.zeros(n, bool)
    rapid[0] = True
    moves = PostMoves.build(tip, axis=axis, rapid=rapid, feed=500.0, tool=1)
    machine = load_machine("fanuc-trunnion-ac")
    posted, read, idx, src, tip_err, axis_err = round_trip(moves, machine)
    tip_bound, axis_bound = increment_bounds(machine, read, idx)
    assert tip_err.max() < tip_bound and axis_err.max() < axis_bound
    assert any("singular" in note for note in posted.notes)
    assert "(PATHCHECK KINEMATICS line" in posted.text
    c = np.array([float(v) for v in re.findall(r" C(-?[0-9.]+)", posted.text)])
    swing = np.abs((np.diff(c) + 180) % 360 - 180)
    a = np.array([float(v) for v in re.findall(r" A(-?[0-9.]+)", posted.text)])
    if beside == 0.0:
        assert any("pole passage" in note for note in posted.notes)
        assert swing.max() < 1e-9 and a.min() < -19 and a.max() > 19  # A crosses 0, C stays
    else:
        assert swing.sum() > 160  # half a turn, unavoidable, and cut as retract-rotate
        assert "in one cut" in posted.text and "retract, rotate, re-enter" in posted.text


@pytest.mark.parametrize(
    ("text", "seconds"),
    [
        ("G21 G94 G0 X0 Y0 Z0\nG1 X10 F600\n", 1.0),  # 10 mm at 600 mm/min
        ("G21 G93 G0 X0 Y0 Z0\nG1 X10 F30\n", 2.0),  # inverse time: 1/30 min
        ("G21 G95 S1200 M3 G0 X0 Y0 Z0\nG1 X10 F0.25\n", 2.0),  # 0.25 mm/rev * 1200 rpm
        ("G20 G95 S1000 M3 G0 X0 Y0 Z0\nG1 X1 F0.01\n", 6.0),  # inch per rev
    ],
)
def test_feed_modes_as_the_control_means_them(text, seconds):
    read = part_motions(read_gcode_text(text, "fanuc"), load_machine("fanuc-hmc"))
    assert read.minutes[-1] * 60 == pytest.approx(seconds)
    length = 10.0 if "G21" in text else 25.4
    assert read.feed[-1] == pytest.approx(length / read.minutes[-1])


def test_rotary_only_feed_in_g94_tcp_is_degrees_per_minute():
    """LinuxCNC with TCP kinematics, a pure rotary block at F1000: 45 deg at 1000 deg/min."""
    text = "G21 G94\nM428\nG0 X10 Y0 Z0 A0 C0\nG1 A45 F1000\n"
    read = part_motions(read_gcode_text(text, "linuxcnc"), load_machine("linuxcnc-xyzac-trt"))
    last = read.block == read.block[-1]
    assert last.sum() == 45  # one piece per degree
    assert read.minutes[last].sum() == pytest.approx(45.0 / 1000.0)
    assert read.tcp.all()
