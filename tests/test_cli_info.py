"""`pathcheck info` through the real CLI entry point: JSON document, text view, and bad input as
one line on stderr with exit code 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from requires import missing

from checker.cli import main

JOB = """PARTNO/INFO TEST
UNITS/MM
CUTTER/10,5
LOAD/TOOL,3
RAPID
GOTO/0,0,20
FEDRAT/300,MMPM
GOTO/0,0,0
GOTO/10,0,0
CIRCLE/10,5,0,0,0,1
GOTO/10,10,0
CUTTER/6
LOAD/TOOL,4
GOTO/10,10,0,0.6,0,0.8
GOTO/20,10,0,-0.6,0,0.8
MYSTERY/1,2
MYSTERY/3
FINI
"""


def run(argv: list[str], capsys) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    out, err = capsys.readouterr()
    return exc.value.code, out, err


@pytest.fixture()
def job(tmp_path: Path) -> Path:
    p = tmp_path / "job.apt"
    p.write_text(JOB)
    return p


def test_info_json_counts(job, capsys):
    code, out, err = run(["info", str(job), "--json", "-"], capsys)
    assert code == 0 and err == ""
    d = json.loads(out)
    assert (d["dialect"], d["units"]) == ("apt", "mm")
    assert d["totals"] == {
        "operations": 2, "records": 18, "goto": 6, "goto_with_axis": 2, "rapid": 1, "arcs": 1,
        "motions": 6, "tool_changes": 2, "distinct_axes": 3, "axis_class": "4-axis-Y",
    }
    op1, op2 = d["operations"]
    assert (op1["tool"], op1["goto"], op1["rapid"], op1["arcs"], op1["axis_class"]) == (
        "T3", 4, 1, 1, "3-axis")
    assert op1["cutter"]["kind"] == "ball" and op1["cutter"]["r"] == 5
    assert (op2["goto"], op2["goto_with_axis"], op2["distinct_axes"], op2["axis_class"]) == (
        2, 2, 2, "4-axis-Y")
    assert d["unknown"] == {"MYSTERY": 2}
    assert d["bbox"] == {"min": [0, 0, 0], "max": [20, 10, 20]}


def test_info_text(job, capsys):
    code, out, _ = run(["info", str(job)], capsys)
    assert code == 0
    assert "apt CL, units mm, 2 operation(s), 18 records" in out
    assert "6 GOTO (2 with axis, 1 rapid), 1 arcs" in out
    assert "unknown statements: MYSTERY x2" in out


def test_multi_axis_class(tmp_path, capsys):
    p = tmp_path / "five.apt"
    p.write_text("CUTTER/6\nGOTO/0,0,0,0,0.6,0.8\n")
    _, out, _ = run(["info", str(p), "--json", "-"], capsys)
    assert json.loads(out)["operations"][0]["axis_class"] == "multi-axis"


BAD = [
    ("malformed.apt", "CUTTER/6\nGOTO/1,2,3\nGOTO/1,2.0.0,3\n", 3, "malformed '2.0.0'"),
    ("truncated.apt", "CUTTER/6\nGOTO/1,$\n2,$\n", 2, "continued with '$' but the file ends"),
    ("dialect.apt", "Dear customer,\nplease find attached\n", 1, "unknown dialect"),
    ("empty.apt", "", None, "empty file"),
    ("binary.apt", "\x7fELF\x02\x01\x01\x00\x00", 1, "binary data"),
    ("nan.apt", "CUTTER/6\nGOTO/0,0,0\nGOTO/nan,0,0\n", 3, "found 'NAN'"),
    ("inf.apt", "CUTTER/6\nFEDRAT/1e400\n", 2, "expected a finite number"),
    ("nocutter.apt", "UNITS/MM\nGOTO/0,0,0\n", 2, "feed move before any CUTTER/"),
    ("arity.apt", "CUTTER/6\nGOTO/1,2,3,4\n", 2, "expected 3 or 6 values"),
]


@pytest.mark.parametrize(("name", "text", "line", "what"), BAD, ids=[b[0] for b in BAD])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, name, text, line, what):
    p = tmp_path / name
    p.write_bytes(text.encode("latin-1"))
    code, out, err = run(["info", str(p), "--json", "-"], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    where = f"{p}:{line}: " if line is not None else f"{p}: "
    assert err.startswith(f"pathcheck: {where}") and what in err


def test_console_script_in_a_subprocess(job, tmp_path):
    exe = Path(sys.executable).with_name("pathcheck")
    if not exe.exists():
        missing(f"console script {exe} not installed (pip install -e .)")
    ok = subprocess.run([str(exe), "info", "--json", "-", str(job)], capture_output=True, text=True,
                        timeout=120)
    assert ok.returncode == 0 and json.loads(ok.stdout)["totals"]["goto"] == 6
    bad = tmp_path / "bad.apt"
    bad.write_text("CUTTER/6\nGOTO/1,2\n")
    res = subprocess.run([str(exe), "info", str(bad)], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr == f"pathcheck: {bad}:2: GOTO/: expected 3 or 6 values (x,y,z[,i,j,k]), " \
        "found 2\n"


def test_part_files_are_handed_to_the_geometry_info(tmp_path, capsys):
    stl = tmp_path / "tri.stl"
    stl.write_text(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 2 0 0\nvertex 0 3 0\n"
        "endloop\nendfacet\nendsolid t\n"
    )
    code, out, err = run(["info", str(stl), "--json", "-"], capsys)
    assert code == 0, err
    d = json.loads(out)
    assert d["kind"] == "mesh" and d["bbox"] == {"min": [0, 0, 0], "max": [2, 3, 0]}
