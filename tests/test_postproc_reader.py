"""G-code reader: modal state, arcs, canned cycles, units, parameters, errors; real programs from
../shared/realdata; our programs accepted by independent PyPI parsers (pygcode, gcodeparser)."""

from __future__ import annotations

import contextlib
import functools
import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from checker.errors import PathcheckError
from checker.postproc.machine import load_machine
from checker.postproc.post import PostMoves, post_program
from checker.postproc.reader import CYCLE, HOME, MACHINE_FRAME, read_gcode, read_gcode_text
from checker.postproc.replay import part_motions


def test_modal_words_incremental_and_inch():
    moves = read_gcode_text(
        "%\nO0001\nN10 G20 G90 G94\nN20 G0 X1. Y2. Z3.\nN30 G1 X2. F10.\nN40 G91 Y-1.\n"
        "N50 G90 G93 Z0 F4\n%\n",
        "fanuc",
    )
    assert moves.units == "inch"
    assert np.allclose(moves.xyz, np.array([[1, 2, 3], [2, 2, 3], [2, 1, 3], [2, 1, 0]]) * 25.4)
    assert moves.motion.tolist() == [0, 1, 1, 1]
    assert moves.feed[1:3].tolist() == [254.0, 254.0] and moves.feed[3] == 4.0  # G93 F as written
    assert moves.feed_mode.tolist() == [94, 94, 94, 93]
    assert moves.line.tolist() == [4, 5, 6, 7]


def test_arcs_ij_r_and_planes():
    text = (
        "G21 G17 G0 X10 Y0 Z0\nG3 X0 Y10 I-10 J0 F100\nG2 X10 Y0 R10\n"
        "G18 G3 X0 Z-10 I-10 K0\nG17 G2 I-10 J0\n"
    )
    moves = read_gcode_text(text, "linuxcnc")
    assert np.allclose(moves.center[1], [0, 0, 0])
    # R10 clockwise from (0,10) to (10,0), the short way: centre (0,0)
    assert np.allclose(moves.center[2], [0, 0, 0], atol=1e-12)
    assert np.allclose(moves.center[3], [0, 0, 0])
    m = load_machine()
    read = part_motions(moves, m, chord_tolerance=0.001)
    arc_pts = read.tip[np.isin(read.line, [2, 3])]
    assert np.allclose(np.hypot(arc_pts[:, 0], arc_pts[:, 1]), 10.0, atol=1e-9)
    # the quarter arc G3 passes through 45 degrees; the G18 arc stays in y = 0 at radius 10 in XZ
    assert np.isclose(
        np.abs(np.arctan2(arc_pts[:, 1], arc_pts[:, 0]) - np.pi / 4).min(), 0, atol=0.02
    )
    g18 = read.tip[read.line == 4]
    assert np.allclose(np.hypot(g18[:, 0], g18[:, 2]), 10.0) and np.allclose(g18[:, 1], 0.0)
    full = read.tip[read.line == 5]  # I/J without an end point: a full circle about (-10, 0)
    assert len(full) > 100 and np.allclose(np.hypot(full[:, 0] + 10.0, full[:, 1]), 10.0)
    assert np.ptp(full[:, 0]) == pytest.approx(20.0, abs=1e-3) and np.allclose(
        full[-1], [0, 0, -10]
    )


def test_canned_cycle_holes_g98_g99():
    text = "G21 G0 X0 Y0 Z50\nG99 G81 X10 Y10 Z-5 R2 F100\nX20\nG98 X30\nG80\nG0 Z60\n"
    moves = read_gcode_text(text, "fanuc")
    cyc = moves.kind == CYCLE
    assert cyc.sum() == 12
    z = moves.xyz[cyc, 2].reshape(3, 4)
    assert np.allclose(z, [[50, 2, -5, 2], [2, 2, -5, 2], [2, 2, -5, 50]])
    assert np.allclose(moves.xyz[cyc, 0].reshape(3, 4)[:, 0], [10, 20, 30])
    assert moves.motion[cyc].reshape(3, 4)[0].tolist() == [0, 0, 1, 0]


def test_home_machine_frame_and_parameters():
    text = (
        "G21 G90 G0 X1 Y2 Z3\nG91 G28 Z0\nG90\nG53 G0 X0 Y0\n"
        "#<depth> = 4\n#1 = [#<depth> * 2 + 1]\nG1 X[#1] Y-[#<depth>] Z#<_hal[unknown]> F100\n"
    )
    moves = read_gcode_text(text, "linuxcnc")
    assert moves.kind.tolist() == [0, HOME, MACHINE_FRAME, 0]
    assert np.isnan(moves.xyz[1, 2]) and np.isnan(moves.xyz[2, :2]).all()
    assert moves.xyz[3, 0] == 9.0 and moves.xyz[3, 1] == -4.0 and np.isnan(moves.xyz[3, 2])
    assert not part_motions(moves, load_machine()).known[1:].any()


@pytest.mark.parametrize(
    ("dialect", "text", "message"),
    [
        ("fanuc", "G0 X1\nG12.3 X2\n", r":2: G12.3 is not a G code of the fanuc dialect"),
        ("linuxcnc", "G0 G1 X1\n", r":1: G0 and G1 are both in modal group 'motion'"),
        ("fanuc", "G1 X1 X2 F10\n", r"word X appears twice"),
        ("fanuc", "G1 X1 (open comment\n", r"comment opened with '\(' at column 7 is not closed"),
        ("linuxcnc", "X1 Y1\n", r"axis words without a motion mode"),
        ("fanuc", "G1 X1.2.3 F1\n", r"expected a word"),
        ("fanuc", "G1 X F1\n", r"expected a number, found 'F1'"),
        ("linuxcnc", "o100 sub\n", r"o-word subroutines"),
        ("fanuc", "G0 X1\nG1 X\x01\n", r":2: expected printable ASCII"),
        ("fanuc", "G0 X0 Y0\nG2 X5 Y0\n", r"arc without centre: expected I/J or R"),
        ("fanuc", "G0 X0 Y0\nG2 X50 Y0 R10\n", r"arc radius R10 cannot join"),
        ("linuxcnc", "M#<nothing>\n", r"M word has no known value"),
        ("linuxcnc", "G1 X1 E2 F100\n", r"E is not a word of the linuxcnc dialect"),
        ("fanuc", "G0 X" + "9" * 400 + "\n", r"expected a number of reasonable size"),
        ("siemens", "N10 G0 X1\nN20 TRAORIX\n", r":2: TRAORIX is not a word of the siemens"),
        ("siemens", "N10 G70\nN20 G20 X1\n", r":2: G20 is not a G code of the siemens"),
        ("millplus", "G7 A5=E1\n", r":1: G7 plane angles A5= B5= C5= must be known numbers"),
        ("heidenhain", "N10 G93 X1 *\n", r"G93 is not a G code of the heidenhain"),
    ],
)
def test_bad_programs_name_file_line_and_expectation(dialect, text, message):
    with pytest.raises(PathcheckError, match=message) as err:
        read_gcode_text(text, dialect, path="prog.nc")
    assert str(err.value).startswith("prog.nc:")


def test_a_and_c_words_are_rejected_for_a_b_table_machine():
    moves = read_gcode_text("G0 X0 Y0 Z0 A0\nG1 X1 A15 F100\n", "linuxcnc", path="p.ngc")
    with pytest.raises(
        PathcheckError, match=r"p.ngc:2: the program turns A \(A15\); machine 'fanuc-hmc'"
    ):
        part_motions(moves, load_machine())


LINUXCNC_FILES = [
    "b-index.ngc",
    "boat-xyzac.ngc",
    "boat-xyzbc.ngc",
    "impeller-7bl-xyzac.ngc",
    "xyzab-tdr-demo.ngc",
]
NX_HORIZONTAL_B = [
    "Toyoda_FH55_horizontal_B.ptp",
    "MoriSeiki_SH8000_horizontal_4axis_B.ptp",
    "Mazak_Nexus510_4axis_mill_B.ptp",
    "Mazak_Nexus510_4axis_part_B.ptp",
    "Kuraki_KBT11DX_horizontal_boring.ptp",
    "MoriSeiki_NMV5000_5axis_mm.ptp",
]


def test_real_linuxcnc_5axis_programs(realdata):
    read = {
        name: read_gcode(realdata / "linuxcnc-5axis-gcode" / name, "linuxcnc")
        for name in LINUXCNC_FILES
    }
    impeller = read["impeller-7bl-xyzac.ngc"]
    assert len(impeller) > 4400
    # the CAM's own footer states the ranges, "( Amin -74.49 Amax   0.00 )" and likewise C, to 0.01
    footer = (realdata / "linuxcnc-5axis-gcode" / "impeller-7bl-xyzac.ngc").read_text()
    for k, axis in ((0, "A"), (2, "C")):
        lo, hi = (float(x) for x in re.search(
            rf"\(\s*{axis}min\s+(\S+)\s+{axis}max\s+(\S+)\s*\)", footer).groups())
        assert np.nanmin(impeller.abc[:, k]) == pytest.approx(lo, abs=0.005), axis
        assert np.nanmax(impeller.abc[:, k]) == pytest.approx(hi, abs=0.005), axis
    assert set(impeller.feed_mode[impeller.motion == 1].tolist()) == {93}
    boat = read["boat-xyzbc.ngc"]
    assert {93, 94} <= set(boat.feed_mode.tolist()) and np.isfinite(boat.abc[:, 1]).any()


def test_real_nx_horizontal_b_programs(realdata):
    machine = load_machine()
    for name in NX_HORIZONTAL_B:
        moves = read_gcode(realdata / "nx-postlib-gcode" / name, "fanuc", units="inch")
        assert len(moves) > 30, name
        if "5axis" not in name:
            read = part_motions(moves, machine)
            assert read.known.sum() > 10, name
    mazak = read_gcode(
        realdata / "nx-postlib-gcode" / "Mazak_Nexus510_4axis_mill_B.ptp", "fanuc", units="inch"
    )
    # the 4-axis surface operation sweeps B from 90 to 180 degrees
    assert np.nanmax(mazak.abc[:, 1]) == 180.0
    sh8000 = read_gcode(
        realdata / "nx-postlib-gcode" / "MoriSeiki_SH8000_horizontal_4axis_B.ptp", "fanuc"
    )
    assert set(np.unique(sh8000.abc[:, 1][np.isfinite(sh8000.abc[:, 1])])) == {0.0, 90.0, 270.0}
    assert sh8000.tool.max() == 5


@functools.lru_cache(maxsize=2)
def _posted(name: str) -> str:
    n = 80
    b = np.linspace(-20.0, 380.0, n)
    th = np.radians(b)
    tip = np.c_[-55.0 * np.sin(th), np.linspace(0, 30, n), 55.0 * np.cos(th)]
    rapid = np.zeros(n, bool)
    rapid[0] = True
    moves = PostMoves.build(
        tip,
        b,
        rapid=rapid,
        feed=700.0,
        spindle=8000.0,
        coolant=8,
        tool=np.where(np.arange(n) < 40, 2, 5),
    )
    return post_program(moves, load_machine(name))


@pytest.mark.parametrize("name", ["fanuc-hmc", "linuxcnc-hmc"])
def test_programs_accepted_by_pygcode(name):
    from pygcode import Line

    text = _posted(name)
    ours = read_gcode_text(text, load_machine(name).dialect)
    ends = {int(line): i for i, line in enumerate(ours.line)}
    state = {}
    checked = 0
    for number, raw in enumerate(text.splitlines(), start=1):
        if raw.strip() == "%":
            continue
        words = {w.letter: w.value for w in Line(raw).block.words}  # raises on what it cannot parse
        state.update({k: float(v) for k, v in words.items() if k in "XYZB"})
        if (
            number in ends
            and ours.kind[ends[number]] == 0
            and np.isfinite(ours.xyz[ends[number]]).all()
        ):
            i = ends[number]
            assert np.allclose([state[k] for k in "XYZ"], ours.xyz[i], atol=1e-9), raw
            assert state["B"] == pytest.approx(ours.abc[i, 1], abs=1e-9), raw
            checked += 1
    assert checked > 70


@pytest.mark.parametrize("name", ["fanuc-hmc", "linuxcnc-hmc"])
def test_programs_accepted_by_gcodeparser(name):
    from gcodeparser import parse_gcode_lines

    text = _posted(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        parsed = list(parse_gcode_lines(text, include_comments=True))
    moves = [p for p in parsed if p.command[0] == "G" and p.command[1] in (0, 1) and p.params]
    assert len(moves) >= 3
    # every block with a G, M or T word was understood (comment lines aside: gcodeparser reads
    # words inside parentheses, such as the T of the header's ISO 8601 date; controls do not)
    lines = text.splitlines()
    with_codes = [k for k, ln in enumerate(lines) if re.search(r"(^|\s)[GMT]\d", ln)
                  and not ln.startswith("(")]
    assert sorted({p.line_index for p in parsed if p.command[0] != ";"
                   and not lines[p.line_index].startswith("(")}) == with_codes
    ours = read_gcode_text(text, load_machine(name).dialect)
    by_line = {int(line): i for i, line in enumerate(ours.line)}
    for p in moves:
        i = by_line[p.line_index + 1]
        if ours.kind[i] != 0:  # G53 / G28 blocks: not work-frame positions
            continue
        for k, letter in enumerate("XYZ"):
            if letter in p.params:
                assert p.params[letter] == pytest.approx(ours.xyz[i, k], abs=1e-9)
        if "B" in p.params:
            assert p.params["B"] == pytest.approx(ours.abc[i, 1], abs=1e-9)
    tools = [p.command for p in parsed if p.command[0] == "T"
             and not lines[p.line_index].startswith("(")]  # the header's time: T02:.. at 2 am
    assert sorted(tools) == [("T", 2), ("T", 5)]


_ALPHABET = "GMXYZABCIJKRFSTNOPQHLDE0123456789.-+ #<>[]=*/();%:,\n_abcxyz\t\x00\xe9"
_WORDS = ["TRAORI", "SUPA", "MCALL CYCLE81(1,0,1,-5,)", "CR=", "G7 A5=", "B5=", "G93 X", "G79",
          "G81 Y", "E254", "=E", "M428", "G43.4", "G141", "G40", "G74 Z", "%P G71 *", "*", "M61 Q"]


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.one_of(st.text(alphabet=_ALPHABET, max_size=12), st.sampled_from(_WORDS)),
             max_size=25).map("".join),
    st.sampled_from(["fanuc", "linuxcnc", "siemens", "heidenhain", "haas", "millplus"]),
)
def test_random_text_raises_only_our_error(text, dialect):
    try:
        moves = read_gcode_text(text, dialect, path="fuzz.nc")
    except PathcheckError as err:
        assert str(err).startswith("fuzz.nc:")
        return
    part_motions_or_error(moves)


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_mutated_programs_raise_only_our_error(data):
    lines = _posted("fanuc-hmc").splitlines()
    k = data.draw(st.integers(0, len(lines) - 1))
    pos = data.draw(st.integers(0, len(lines[k])))
    junk = data.draw(st.text(alphabet=_ALPHABET, min_size=1, max_size=6))
    lines[k] = lines[k][:pos] + junk + lines[k][pos + data.draw(st.integers(0, 3)) :]
    try:
        moves = read_gcode_text("\n".join(lines), "fanuc", path="m.nc")
    except PathcheckError as err:
        assert str(err).startswith("m.nc:")
        return
    part_motions_or_error(moves)


def part_motions_or_error(moves) -> None:
    """Reading back into the part frame either works or is our error, never a crash."""
    for name in ("fanuc-hmc", "fanuc-trunnion-ac", "heidenhain-head-table-bc"):
        with contextlib.suppress(PathcheckError):
            part_motions(moves, load_machine(name))


def test_siemens_words_traori_cycles_cr_and_units():
    text = (
        "N1 G00 G90 G70 G40\nN2 SUPA G00 Z-.1 D0\nN3 T5 M6\nN4 TRAORI\n"
        "N5 G00 X1. Y0 Z2. B10. C20.\nN6 G02 X0 Y1. CR=1. F10\nN7 F.4\n"
        "N8 MCALL CYCLE81(2.,1.,.1,-.5,)\nN9 X2. Y2.\nN10 MCALL\nN11 TRAFOOF\nN12 G0 X3.\n"
    )
    moves = read_gcode_text(text, "siemens", path="s.mpf")
    assert moves.units == "inch" and moves.tool.max() == 5
    assert moves.kind[0] == MACHINE_FRAME and np.isnan(moves.xyz[0, 2])
    arc = np.flatnonzero(moves.motion == 2)[0]
    assert np.allclose(moves.center[arc, :2], [25.4, 25.4])  # R 1 in, (1,0) -> (0,1) CW: short
    hole = moves.xyz[moves.kind == CYCLE] / 25.4  # rapid over, R + SDIS, depth DP, back to RTP
    assert np.allclose(hole[:, 2], [2.0, 1.1, -0.5, 2.0]) and np.allclose(hole[:, :2], 2.0)
    assert moves.tcp[1:-1].all() and not moves.tcp[-1]
    assert np.allclose(moves.abc[1, 1:], [10.0, 20.0])


def test_millplus_datum_tilted_plane_and_cycle_call():
    """G93 shifts the datum; G7 A5= B5= C5= tilts the plane (X, then Y, then Z): X Y Z in the
    tilted frame, the tool along its Z; G8x defines a hole, G79 drills it at X Y Z."""
    text = (
        "%\nO0001 (P)\nN10 G71\nN20 G93 X10. Y20. Z30.\nN30 G0 X1. Y0 Z0\n"
        "N40 G7 A5=0 B5=90. C5=0 L1=1\nN50 G0 X0 Y0 Z5.\nN60 G81 Y2. Z-4. B10. F100\n"
        "N70 G79 X0 Y0 Z0\nN80 G7 A5=0 B5=0 C5=0 L1=1\nN90 G0 X0 Y0 Z0\n%\n"
    )
    moves = read_gcode_text(text, "millplus", path="p.pm")
    assert np.allclose(moves.xyz[0], [11.0, 20.0, 30.0])
    # B5=90: tilted X is work -Z, tilted Z is work +X: Z5 in the plane is 5 mm along work +X
    assert np.allclose(moves.xyz[1], [15.0, 20.0, 30.0])
    assert np.allclose(moves.tool_axis[1], [1.0, 0.0, 0.0]) and moves.tcp[1]
    hole = moves.xyz[moves.kind == CYCLE][:, 0] - 10.0  # along the tilted Z = work X
    assert np.allclose(hole, [10.0, 2.0, -4.0, 10.0])
    assert np.allclose(moves.xyz[-1], [10.0, 20.0, 30.0]) and not moves.tcp[-1]
    m = load_machine("dmc160u-millplus")
    pm = part_motions(moves, m)
    assert np.allclose(pm.axis[pm.line == moves.line[1]][-1], [1.0, 0.0, 0.0])


def test_heidenhain_program_frame_and_tool_call():
    text = "%P G70 *\nN10 T3 G17 S1000 *\nN20 G00 X1 Y2 Z3 *\nN30 M128 *\nN99999999 %P G70 *\n"
    moves = read_gcode_text(text, "heidenhain", path="p.h")
    assert moves.units == "inch" and moves.tool[0] == 3
    assert np.allclose(moves.xyz[0], np.array([1, 2, 3]) * 25.4)
