"""`pathcheck check-gcode`: reads a program for a machine and reports its moves; bad input is
one line and exit code 2."""

from __future__ import annotations

import json

import numpy as np
import pytest

from checker.cli import main
from checker.postproc.machine import load_machine
from checker.postproc.post import PostMoves, post_program
from checker.postproc.writer import write_program


def run(argv: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    return int(exc.value.code)


@pytest.fixture
def program(tmp_path):
    n = 50
    b = np.linspace(-25.0, 35.0, n)
    th = np.radians(b)
    tip = np.c_[-60.0 * np.sin(th), np.linspace(-5.0, 5.0, n), 60.0 * np.cos(th)]
    rapid = np.zeros(n, bool)
    rapid[0] = True
    moves = PostMoves.build(tip, b, rapid=rapid, feed=800.0, spindle=6000.0, tool=4)
    return write_program(post_program(moves, load_machine("linuxcnc-hmc")), tmp_path / "prog.ngc")


def test_check_gcode_reports_moves(program, tmp_path, capsys):
    out = tmp_path / "summary.json"
    code = run(
        [
            "check-gcode",
            str(program),
            "--machine",
            "linuxcnc-hmc",
            "--cutter",
            "CUTTER/6,3",
            "--json",
            str(out),
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "linuxcnc G-code, mm, machine linuxcnc-hmc" in text
    doc = json.loads(out.read_text())
    assert doc["tools"] == [4]
    assert doc["points"]["known"] >= 50
    assert doc["b_deg"] == pytest.approx([-25.0, 35.0], abs=1e-4)
    assert doc["feed_mm_min"] == pytest.approx([800.0, 800.0], rel=2e-3)
    # every programmed tip lies on the radius-60 ring about Y
    assert doc["bbox_mm"][1] == pytest.approx([-5.0, 5.0], abs=1e-4)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--machine", "no-such-machine"], "unknown machine 'no-such-machine'"),
        (
            ["--machine", "fanuc-hmc", "--dialect", "okuma"],
            "unknown G-code dialect 'okuma'",
        ),
        (["--machine", "fanuc-hmc", "--cutter", "CUTTER/-3"], "CUTTER"),
    ],
)
def test_check_gcode_bad_input_is_exit_2(program, capsys, args, message):
    assert run(["check-gcode", str(program), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pathcheck: ") and message in err and "\n" not in err


def test_check_gcode_five_axis_program_on_b_table_machine(tmp_path, capsys):
    prog = tmp_path / "ac.ngc"
    prog.write_text("G21 G90\nG0 X0 Y0 Z10 A0 C0\nG93 G1 X5 A12 C30 F2\nM2\n")
    assert run(["check-gcode", str(prog), "--machine", "linuxcnc-hmc"]) == 2
    assert f"{prog}:3: the program turns A (A12)" in capsys.readouterr().err
