"""CL reader on small hand-written files: every number checked against the value it must have."""

from __future__ import annotations

import numpy as np
import pytest

from checker.apt import read_cl, read_cl_text

MM = 25.4


def apt(*lines: str) -> str:
    return "\n".join(lines) + "\n"


def test_basic_apt_motions_feed_rapid_and_lines():
    tp = read_cl_text(
        apt(
            "PARTNO/DEMO, PART 1",
            "UNITS/MM",
            "CUTTER/10",
            "SPINDL/3000,RPM,CLW",
            "RAPID",
            "GOTO/0,0,50",
            "FEDRAT/500,MMPM",
            "GOTO/0,0,5",
            "GOTO/10.5,-2,5",
            "FINI",
        )
    )
    m = tp.motion_arrays()
    assert tp.dialect == "apt" and tp.units == "mm"
    np.testing.assert_allclose(m.tip, [[0, 0, 50], [0, 0, 5], [10.5, -2, 5]])
    np.testing.assert_allclose(m.axis, [[0, 0, 1]] * 3)
    assert m.rapid.tolist() == [True, False, False]  # RAPID applies to the next move only
    assert np.isnan(m.feed[0]) and m.feed[1:].tolist() == [500, 500]
    assert m.spindle.tolist() == [3000] * 3
    assert m.line.tolist() == [6, 8, 9]
    assert m.op.tolist() == [0, 0, 0]
    last = m.motion(2)
    assert (last.tip.tolist(), last.rapid, last.feed, last.line) == ([10.5, -2, 5], False, 500, 9)
    assert tp.records[0].text == "DEMO, PART 1"  # free text keeps its commas
    assert tp.operations[0].cutter.d == 10 and tp.operations[0].cutter.kind == "flat"
    assert tp.unknown == {}
    assert tp.ignored == {"FINI": 1, "PARTNO": 1, "UNITS": 1}


def test_inch_file_converted_to_mm_but_angles_kept():
    tp = read_cl_text(
        apt(
            "UNITS/INCHES",
            "CUTTER/0.5,0.1,0.158367,0.1,0,5,2",
            "FEDRAT/10",
            "GOTO/1,2,3",
            "FEDRAT/0.01,IPR",
            "SPINDL/1000,RPM",
            "GOTO/1,2,4",
        )
    )
    m = tp.motion_arrays()
    assert tp.units == "inch"
    np.testing.assert_allclose(m.tip, [[MM, 2 * MM, 3 * MM], [MM, 2 * MM, 4 * MM]])
    np.testing.assert_allclose(m.feed, [10 * MM, 0.01 * MM * 1000])  # IPM default, IPR * rpm
    c = tp.operations[0].cutter
    assert c.d == pytest.approx(0.5 * MM) and c.r == pytest.approx(0.1 * MM)
    assert np.degrees(c.theta) == pytest.approx(5.0)  # beta is an angle: not scaled


def test_nx_units_from_feed_and_listing_header():
    text = apt(
        "Information listing created by\tsomeone",
        "Date\t18-Dec-2021 21:07:42",
        "",
        "TOOL PATH/FACE,TOOL,FLAT_0.5",
        "TLDATA/MILL,0.5000,0.0000,2.0000,0.0000,0.0000",
        "MSYS/0.0000,0.0000,0.0000,1.0000000,0.0000000,0.0000000,0.0000000,1.0000000,0.0000000",
        "$$ centerline data",
        "PAINT/COLOR,186",
        "RAPID",
        "GOTO/1.0000,1.0000,1.0000,0.0000000,0.0000000,1.0000000",
        "FEDRAT/IPM,20.0000",
        "GOTO/2.0000,1.0000,1.0000",
        "END-OF-PATH",
        "Tool Path Listing has 12 lines.",
    )
    tp = read_cl_text(text)
    assert tp.dialect == "clsf" and tp.units == "inch"
    m = tp.motion_arrays()
    np.testing.assert_allclose(m.tip, [[MM, MM, MM], [2 * MM, MM, MM]])
    np.testing.assert_allclose(m.feed[1], 20 * MM)
    op = tp.operations[0]
    assert (op.name, op.tool_name) == ("FACE", "FLAT_0.5")
    assert op.cutter.d == pytest.approx(0.5 * MM)
    assert [r.word for r in tp.records[:2]] == ["$$", "$$"]  # header kept as comments
    assert tp.records[-1].text == " Tool Path Listing has 12 lines."
    assert tp.ignored["PAINT"] == 1 and tp.unknown == {}


def test_nx_axis_is_modal_and_resets_at_a_new_operation():
    tp = read_cl_text(
        apt(
            "TOOL PATH/A,TOOL,T",
            "TLDATA/MILL,10,5,50,0,0",
            "GOTO/0,0,10,0.6,0,0.8",
            "GOTO/1,0,10",
            "GOTO/2,0,10,0,0.6,0.8",
            "GOTO/3,0,10",
            "END-OF-PATH",
            "TOOL PATH/B,TOOL,T",
            "TLDATA/MILL,10,5,50,0,0",
            "GOTO/4,0,10",
            "END-OF-PATH",
        )
    )
    m = tp.motion_arrays()
    np.testing.assert_allclose(
        m.axis, [[0.6, 0, 0.8], [0.6, 0, 0.8], [0, 0.6, 0.8], [0, 0.6, 0.8], [0, 0, 1]]
    )
    assert m.op.tolist() == [0, 0, 0, 0, 1]
    assert [o.name for o in tp.operations] == ["A", "B"]
    assert (tp.operations[0].first_motion, tp.operations[0].end_motion) == (0, 4)


def test_tlaxis_and_multax():
    tp = read_cl_text(
        apt("CUTTER/6", "TLAXIS/0,-1,0", "GOTO/0,0,0", "MULTAX/ON", "GOTO/1,0,0,1,0,0",
            "MULTAX/OFF", "GOTO/2,0,0")
    )
    np.testing.assert_allclose(tp.motion_arrays().axis, [[0, -1, 0], [1, 0, 0], [0, -1, 0]])


def test_csys_applied_unless_trntyp_world():
    # 90 degrees about z, then shifted by (100, 0, 5): file x -> part y
    csys = "CSYS/0,-1,0,100,1,0,0,0,0,0,1,5"
    tp = read_cl_text(apt("CUTTER/6", csys, "GOTO/10,0,0,1,0,0"))
    m = tp.motion_arrays()
    np.testing.assert_allclose(m.tip, [[100, 10, 5]], atol=1e-12)
    np.testing.assert_allclose(m.axis, [[0, 1, 0]], atol=1e-12)
    assert tp.frames[0].applied
    world = read_cl_text(apt("CUTTER/6", "TRNTYP/WORLD,0,0,0", csys, "GOTO/10,0,0,1,0,0"))
    np.testing.assert_allclose(world.motion_arrays().tip, [[10, 0, 0]])
    assert not world.frames[0].applied


def test_msys_origin_and_axes_in_inches():
    # MCS origin (1,2,3) in, X axis = part Y, Y axis = part -X, Z = part Z
    text = apt(
        "TOOL PATH/A,TOOL,T",
        "TLDATA/MILL,0.5,0,2,0,0",
        "MSYS/1,2,3,0,1,0,-1,0,0",
        "FEDRAT/IPM,10",
        "GOTO/1,0,0,1,0,0",
    )
    m = read_cl_text(text).motion_arrays()
    np.testing.assert_allclose(m.tip, [[MM, 3 * MM, 3 * MM]], atol=1e-12)
    np.testing.assert_allclose(m.axis, [[0, 1, 0]], atol=1e-12)


def test_godlta_along_axis_and_by_vector():
    tp = read_cl_text(apt("CUTTER/6", "GOTO/0,0,0,0,0.6,0.8", "GODLTA/10", "GODLTA/1,2,3"))
    np.testing.assert_allclose(tp.motion_arrays().tip, [[0, 0, 0], [0, 6, 8], [1, 8, 11]])


def test_continuation_comments_and_free_text():
    tp = read_cl_text(
        apt(
            "CUTTER/6 $$ six mm flat",
            "GOTO/1,$",
            "   2,$  $$ half way",
            "   3",
            "PPRINT/HELLO, WORLD $ not a continuation",
            "INSERT/[HOLDER=C40] 6MM, 2FL",
            "$$ OPERATION NAME : ROUGH",
            "COOLNT/FLOOD",
            "CSI_SET_FLUTE_LENGTH/19.",
        )
    )
    goto = tp.records[1]
    assert (goto.word, goto.args, goto.line, goto.comment) == ("GOTO", (1.0, 2.0, 3.0), 2,
                                                                " half way")
    assert tp.records[0].comment == " six mm flat"
    assert tp.records[2].text == "HELLO, WORLD $ not a continuation"
    assert tp.records[3].text == "[HOLDER=C40] 6MM, 2FL"
    assert tp.operations[0].name == "ROUGH"
    assert tp.unknown == {"CSI_SET_FLUTE_LENGTH": 1}
    assert tp.ignored == {"$$": 1, "INSERT": 1, "PPRINT": 1}  # COOLNT is used: coolant


def test_card_image_columns_73_to_80_ignored():
    body = ["PARTNO/CARDS", "CUTTER/10", "GOTO/1,2,3", "GOTO/4,5,6"]
    text = "\n".join(f"{s:<72}{10 * (k + 1):08d}" for k, s in enumerate(body)) + "\n"
    m = read_cl_text(text).motion_arrays()
    np.testing.assert_allclose(m.tip, [[1, 2, 3], [4, 5, 6]])


def test_operations_split_at_tool_changes_and_cycles_flagged():
    tp = read_cl_text(
        apt(
            "CUTTER/6",
            "LOAD/TOOL,1",
            "GOTO/0,0,0",
            "CUTTER/8",
            "LOAD/TOOL,2",
            "CYCLE/DRILL,FEDTO,5,MMPM,100",
            "GOTO/1,1,0",
            "CYCLE/OFF",
            "GOTO/2,2,0",
        )
    )
    assert [(o.tool_name, o.tool_number, o.cutter.d) for o in tp.operations] == [
        ("T1", 1, 6.0),
        ("T2", 2, 8.0),
    ]
    assert [t.tool_number for t in tp.tool_changes] == [1, 2]
    m = tp.motion_arrays()
    assert m.op.tolist() == [0, 1, 1] and m.cycle.tolist() == [False, True, False]
    assert np.isnan(m.feed[0]) and m.feed[1] == 100 and np.isnan(m.feed[2])  # the cycle's feed
    assert (tp.operations[1].first_record, tp.operations[1].end_record) == (3, 9)


def test_read_cl_reads_a_file(tmp_path):
    f = tmp_path / "job.apt"
    f.write_bytes(b"CUTTER/6\r\nGOTO/1,2,3\r\n")
    tp = read_cl(f)
    assert tp.path == str(f) and tp.motion_arrays().tip.tolist() == [[1, 2, 3]]


def test_creo_style_spaces_around_the_slash():
    tp = read_cl_text(
        apt(
            "$$-> MFGNO / DEMO",
            "PARTNO / DEMO",
            "UNITS / MM",
            "MACHIN / UNCX01, 1",
            "CUTTER / 10.000000",
            "LOADTL / 7",
            "SPINDL / RPM, 1200.000000, CLW",
            "FEDRAT / 250.000000, MMPM",
            "GOTO / 1.0000000000, 2.0000000000, 3.0000000000",
            "ORIGIN / 1, 2, 3",
        )
    )
    m = tp.motion_arrays()
    assert m.tip.tolist() == [[1, 2, 3]] and m.feed.tolist() == [250] and m.spindle[0] == 1200
    assert tp.operations[0].tool_number == 7
    assert tp.unknown == {"ORIGIN": 1}  # a statement that would move the part is never hidden


def test_a_feed_between_rapid_and_goto_cancels_the_rapid():
    m = read_cl_text(apt("CUTTER/6", "RAPID", "FEDRAT/100", "GOTO/1,2,3", "RAPID", "GOTO/0,0,9"))\
        .motion_arrays()
    assert m.rapid.tolist() == [False, True] and m.feed[0] == 100 and np.isnan(m.feed[1])


def test_dos_end_of_file_mark_and_crlf():
    tp = read_cl_text("CUTTER/6\r\nGOTO/1,2,3\r\nFINI\r\n\x1a")
    assert tp.motion_arrays().tip.tolist() == [[1, 2, 3]] and tp.records[-1].word == "FINI"
