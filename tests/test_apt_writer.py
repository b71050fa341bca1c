"""APT writer: exact numbers, `$` continuation under 72 columns, comments and free text kept."""

from __future__ import annotations

import io

import pytest

from checker.apt import read_cl, read_cl_text, write_apt
from checker.apt.write import apt_text, format_value
from checker.errors import PathcheckError

SOURCE = """PARTNO/WRITER, TEST
$$ a comment line
UNITS/INCHES
CUTTER/0.25 $$ quarter inch flat
RAPID/
GOTO/0.1234567890123,-2.5e-5,1.0D+01,0.57735026918962573,0.57735026918962573,$
   0.57735026918962573
FEDRAT/IPM,12.5
CYCLE/DEEP2,FEDTO,0.5,1STPECK,0.1,IPM,3.,RAPTO,0.1
INSERT/[HOLDER=C40] text, with commas $ and a dollar
RAPID
FINI
"""


@pytest.mark.parametrize(
    ("value", "text"),
    [(5.0, "5"), (-0.1736, "-0.1736"), (1e-05, "0.00001"), (0.1 + 0.2, "0.30000000000000004"),
     (123456789.125, "123456789.125"), ("CLW", "CLW")],
)
def test_format_value_is_shortest_exact_positional(value, text):
    assert format_value(value) == text
    if not isinstance(value, str):
        assert float(text) == value


def test_written_text_reads_back_to_identical_records():
    tp = read_cl_text(SOURCE)
    text = apt_text(tp)
    back = read_cl_text(text, column72=True)  # card-image readers see the same statements
    assert len(back.records) == len(tp.records)
    for a, b in zip(tp.records, back.records, strict=True):
        assert a.same_as(b, rel=0.0), (a, b)
    assert all(len(s) <= 72 for s in text.splitlines() if not s.startswith(("INSERT", "PARTNO")))
    goto = [s for s in text.splitlines() if s.startswith("GOTO")][0]
    assert goto.endswith(",$")  # the long GOTO is continued
    assert "RAPID/\n" in text and "\nRAPID\n" in text  # with and without the slash, as read
    assert "CUTTER/0.25 $$ quarter inch flat" in text
    assert "INSERT/[HOLDER=C40] text, with commas $ and a dollar" in text


def test_write_to_path_and_stream(tmp_path):
    tp = read_cl_text(SOURCE)
    f = tmp_path / "out.apt"
    write_apt(tp, f)
    buf = io.StringIO()
    write_apt(tp, buf)
    assert f.read_text() == buf.getvalue()
    assert read_cl(f).motion_arrays().tip.tolist() == tp.motion_arrays().tip.tolist()


def test_write_to_a_folder_that_does_not_exist(tmp_path):
    tp = read_cl_text(SOURCE)
    with pytest.raises(PathcheckError, match="cannot write APT file"):
        write_apt(tp, tmp_path / "missing" / "out.apt")
