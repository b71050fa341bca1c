"""A G-code program that states no units (no G20/G21): `check-gcode` reads it in `--units`,
else in the units its machine file states, saying so on stderr; with neither it refuses (one
line, exit 2). Which real programs state their units is checked against a scan of their words."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from checker.cli import main
from checker.postproc.machine import load_machine
from checker.postproc.reader import read_gcode

PROGRAM = """%
G17 G90 G54
G0 X10 Y0 Z5
G1 Z0 F100
G1 X20
M30
%
"""


def _run(args: list[str], capsys) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as ex:
        main(args)
    out = capsys.readouterr()
    return ex.value.code, out.out, out.err


@pytest.fixture()
def files(tmp_path) -> tuple[Path, Path]:
    """A program without units and a machine file that does not state its units."""
    program = tmp_path / "bare.ngc"
    program.write_text(PROGRAM)
    machine = tmp_path / "bare.toml"
    machine.write_text('name = "bare"\ndialect = "linuxcnc"\n')
    return program, machine


def test_no_units_anywhere_is_refused_in_one_line(files, capsys):
    program, machine = files
    code, out, err = _run(["check-gcode", str(program), "--machine", str(machine)], capsys)
    assert code == 2 and out == ""
    assert err == (f"pathcheck: {program}: the program states no units (no G20/G21) and "
                   "machine bare gives none: expected --units mm|inch\n")


def test_units_option_is_used_and_said(files, tmp_path, capsys):
    program, machine = files
    out_json = tmp_path / "inch.json"
    code, _, err = _run(["check-gcode", str(program), "--machine", str(machine), "--units",
                         "inch", "--json", str(out_json)], capsys)
    assert code in (0, 1)  # machine checks of a bare machine may flag; the reading is the point
    assert err == f"pathcheck: note: {program} states no units (no G20/G21): read in inch, " \
                  "--units\n"
    doc = json.loads(out_json.read_text())
    assert doc["units"] == "inch"
    assert doc["axes"]["X"] == pytest.approx([254.0, 508.0])  # X10..X20 inch, in mm
    assert doc["feed_mm_min"] == pytest.approx([2540.0, 2540.0])  # F100 inch/min


def test_the_machine_files_units_are_used_and_said(files, capsys):
    program, _ = files
    assert "units" in load_machine("linuxcnc-hmc").model_fields_set  # its file states mm
    code, out, err = _run(["check-gcode", str(program), "--machine", "linuxcnc-hmc"], capsys)
    assert code in (0, 1) and ", mm, machine linuxcnc-hmc" in out
    assert err == (f"pathcheck: note: {program} states no units (no G20/G21): read in mm, "
                   "the units of machine linuxcnc-hmc\n")


@pytest.mark.parametrize("later_error", ["B axis", "part file"])
def test_the_note_is_not_shown_before_a_later_input_error(files, tmp_path, capsys, later_error):
    """The units note is shown only when the command succeeds: a program without units that
    then fails (it turns B on a table-table A/C machine; its part file is not a part) ends with
    its one error line alone (the nightly fuzzing's G-code case 477 printed both)."""
    program, _ = files
    args = ["check-gcode", str(program), "--machine", "linuxcnc-xyzac-trt"]
    if later_error == "B axis":
        program.write_text(PROGRAM.replace("G1 X20", "G1 X20 B32"))
        expected = f"{program}:5: the program turns B (B32)"
    else:
        part = tmp_path / "part.stl"
        part.write_text("solid nothing\n")
        args += ["--part", str(part), "--cutter", "CUTTER/6,3", "--no-store"]
        expected = str(part)
    code, _, err = _run(args, capsys)
    assert code == 2, err
    assert len(err.splitlines()) == 1 and expected in err and "pathcheck: note:" not in err, err


def test_a_program_that_states_its_units_gets_no_note(files, capsys):
    program, machine = files
    program.write_text(PROGRAM.replace("G17 G90 G54", "G17 G90 G54 G20"))
    code, out, err = _run(["check-gcode", str(program), "--machine", str(machine)], capsys)
    assert code in (0, 1) and err == "" and ", inch, machine bare" in out


_UNITS_WORD = re.compile(r"(?<![A-Z0-9.])G0*(20|21)(?![0-9.])")


@pytest.mark.parametrize("name", ["b-index", "boat-xyzac", "boat-xyzbc", "impeller-7bl-xyzac",
                                  "xyzab-tdr-demo"])
def test_which_real_programs_state_their_units(realdata, name):
    """The reader's `units_stated` against a scan of the words outside comments: three of
    the five LinuxCNC programs state none, so their machine file's units are what is read."""
    path = realdata / "linuxcnc-5axis-gcode" / f"{name}.ngc"
    code = re.sub(r"\([^)]*\)|;.*", "", path.read_text(encoding="latin-1").upper())
    stated = _UNITS_WORD.search(code) is not None
    assert read_gcode(path, "linuxcnc").units_stated is stated
    assert stated == (name in ("b-index", "xyzab-tdr-demo"))
