"""Bad CL input: one PathcheckError naming the line, what was expected and what was found."""

from __future__ import annotations

import numpy as np
import pytest

from checker.apt import read_cl, read_cl_text
from checker.errors import PathcheckError

# (name, text, expected message: "<string>:LINE: ...")
CASES = [
    ("malformed number", "CUTTER/6\nGOTO/1.2.3,0,0\n",
     r"^<string>:2: GOTO/: expected a number or a word at position 1, found malformed '1\.2\.3'"),
    ("malformed sign", "CUTTER/6\nGOTO/1,--2,0\n", r"^<string>:2: GOTO/: .*found malformed '--2'"),
    ("truncated continuation", "CUTTER/6\nGOTO/1,2,$\n",
     r"^<string>:2: statement continued with '\$' but the file ends"),
    ("unknown dialect", "hello world\nthis is not a tool path\n",
     r"^<string>:1: unknown dialect: expected APT-CL .* found no such statement"),
    ("empty file", "", r"^<string>: empty file: expected CL statements"),
    ("blank file", " \n\n\t\n", r"^<string>: empty file"),
    ("comments only", "$$ GOTO/1,2,3\n$$ nothing else\n", r"^<string>:1: unknown dialect"),
    ("binary garbage", "GOTO/1,2,3\n\x00\x01\x02\xff",
     r"^<string>:2: expected a text CL file, found binary data \(byte 0x00\)"),
    ("NaN", "CUTTER/6\nGOTO/NaN,0,0\n",
     r"^<string>:2: GOTO/: expected a number at position 1 \(x,y,z\[,i,j,k\]\), found 'NAN'"),
    ("inf word", "CUTTER/6\nGOTO/0,inf,0\n", r":2: GOTO/: expected a number at position 2"),
    ("overflow", "CUTTER/6\nGOTO/0,0,1e999\n",
     r"^<string>:2: GOTO/: expected a finite number .* at position 3, found '1e999'"),
    ("GOTO before any cutter", "UNITS/MM\nRAPID\nGOTO/0,0,50\nGOTO/0,0,0\n",
     r"^<string>:4: GOTO/: feed move before any CUTTER/ or TLDATA/ statement"),
    ("GOTO arity", "CUTTER/6\nGOTO/1,2\n",
     r"^<string>:2: GOTO/: expected 3 or 6 values \(x,y,z\[,i,j,k\]\), found 2"),
    ("CSYS arity", "CUTTER/6\nCSYS/1,0,0,0,1,0,0,0,1\n", r":2: CSYS/: expected 12 values"),
    ("CUTTER arity", "CUTTER/10,2,3\n", r"^<string>:1: CUTTER: expected 1, 2 or 7 values"),
    ("zero axis", "CUTTER/6\nGOTO/1,2,3,0,0,0\n", r":2: expected a unit tool axis i,j,k"),
    ("not a rotation", "CUTTER/6\nCSYS/1,0,0,0,0,2,0,0,0,0,1,0\nGOTO/0,0,0\n",
     r":2: CSYS/: expected an orthonormal right-handed rotation"),
    ("bad feed", "CUTTER/6\nFEDRAT/FAST\n", r":2: FEDRAT/: expected a feed value"),
    ("bad units", "UNITS/FURLONGS\nCUTTER/6\n",
     r":1: UNITS/: expected INCHES or MM, found 'FURLONGS'"),
    ("mixed units", "UNITS/MM\nCUTTER/6\nUNITS/INCHES\n", r":3: UNITS/: units change from mm"),
    ("bad tool number", "CUTTER/6\nLOAD/TOOL,1.5\n", r":2: LOAD/: expected a tool number"),
    ("no slash", "CUTTER/6\nGOTO 1,2,3\n",
     r":2: expected a statement WORD/values, found 'GOTO 1,2,3'"),
    ("empty field", "CUTTER/6\nGOTO/1,,3\n", r":2: GOTO/: expected a value at position 2"),
    ("bad cutter", "CUTTER/10,6\n", r":1: CUTTER: corner radius r=6 is larger than half"),
    ("too many turns", "CUTTER/6\nGOTO/1,0,0\nCIRCLE/0,0,0,0,0,1,TIMES,1e9\nGOTO/1,0,0\n",
     r":3: CIRCLE/: expected TIMES,n with a whole 0 <= n <= 1000"),
]


@pytest.mark.parametrize(("name", "text", "pattern"), CASES, ids=[c[0] for c in CASES])
def test_bad_input_raises_pathcheck_error_with_line(name, text, pattern):
    with pytest.raises(PathcheckError, match=pattern) as info:
        read_cl_text(text)
    assert "\n" not in str(info.value)


def test_rapid_preamble_before_the_cutter_is_allowed():
    tp = read_cl_text("RAPID\nGOTO/0,0,50\nCUTTER/6\nGOTO/0,0,0\n")
    assert tp.motion_arrays().rapid.tolist() == [True, False]


def test_require_cutter_can_be_switched_off():
    tp = read_cl_text("GOTO/0,0,0\nGOTO/1,0,0\n", require_cutter=False)
    assert len(tp.motion_arrays()) == 2 and tp.operations[0].cutter is None


def test_missing_file_and_binary_file(tmp_path):
    with pytest.raises(PathcheckError, match=r"nope\.apt: cannot read CL file"):
        read_cl(tmp_path / "nope.apt")
    f = tmp_path / "garbage.apt"
    f.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(PathcheckError, match=r"garbage\.apt:1: expected a text CL file"):
        read_cl(f)


def test_arc_sampling_refuses_absurd_point_counts_and_bad_tolerances():
    tp = read_cl_text("CUTTER/6\nGOTO/9e4,0,0\nCIRCLE/0,0,0,0,0,1\nGOTO/0,9e4,0\n")
    with pytest.raises(PathcheckError, match=r"line 3: CIRCLE/: sampling this arc .* needs"):
        tp.motion_arrays(arc_chord_tol=1e-9)
    with pytest.raises(PathcheckError, match="chord tolerance must be > 0"):
        tp.motion_arrays(arc_chord_tol=0.0)


def test_long_digit_strings_are_refused_by_magnitude():
    with pytest.raises(PathcheckError, match=r"<string>:2: expected coordinates of at most 1e\+15"):
        read_cl_text("CUTTER/6\nGOTO/" + "9" * 400 + ",0,0\n")
    with pytest.raises(PathcheckError, match=r":2: expected a unit tool axis"):
        read_cl_text("CUTTER/6\nGOTO/0,0,0,0,0," + "9" * 400 + "\n")


JOB = ("PARTNO/BOM AND CR\nUNITS/MM\nCUTTER/10,5\nFEDRAT/500,MMPM\nGOTO/0,0,5\nGOTO/10,0,5\n"
       "GOTO/10,5,5,0,0.6,0.8\nGOTO/0,5,5\nFINI\n")


def _same_path(a, b) -> None:
    np.testing.assert_allclose(a.motions.tip, b.motions.tip, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.motions.axis, b.motions.axis, rtol=0, atol=1e-12)
    assert a.motions.line.tolist() == b.motions.line.tolist()
    assert [r.word for r in a.records] == [r.word for r in b.records]


def test_a_utf8_byte_order_mark_is_skipped(tmp_path):
    plain, bom = tmp_path / "plain.apt", tmp_path / "bom.apt"
    plain.write_text(JOB)
    bom.write_bytes(b"\xef\xbb\xbf" + JOB.encode())
    want = read_cl(plain)
    assert want.motions.line.tolist() == [5, 6, 7, 8]
    _same_path(read_cl(bom), want)
    _same_path(read_cl_text("\ufeff" + JOB), want)
    assert read_cl(bom).records[0].text == "BOM AND CR"  # the mark is not part of the name


def test_cr_only_line_ends_are_read_as_line_ends(tmp_path):
    plain, cr = tmp_path / "plain.apt", tmp_path / "cr.apt"
    plain.write_text(JOB)
    cr.write_bytes(JOB.replace("\n", "\r").encode())
    want = read_cl(plain)
    _same_path(read_cl(cr), want)  # same motions on the same line numbers
    _same_path(read_cl_text(JOB.replace("\n", "\r")), want)
    with pytest.raises(PathcheckError, match=r"cr2\.apt:3: CUTTER: expected 1, 2 or 7 values"):
        bad = tmp_path / "cr2.apt"
        bad.write_bytes(JOB.replace("CUTTER/10,5", "CUTTER/10,5,1").replace("\n", "\r").encode())
        read_cl(bad)
