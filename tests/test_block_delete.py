"""Block delete: a block starting with `/` is skipped while the switch is on (the default) and
run while it is off, modes included; against the closed-form moves, pygcode (which has no
switch: it runs every block, so it reads the program with `/` lines taken out for "on") and,
where installed, LinuxCNC's rs274 (`-b` turns its switch on)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from checker.cli import main
from checker.postproc.reader import BLOCK_DELETE_RUN, BLOCK_DELETE_SKIPPED, read_gcode_text

#: the `/` blocks would rapid elsewhere, plunge 7 mm deeper (a gouge) and switch to G91
PROGRAM = """G21 G90 G17
G0 X0 Y0 Z10
/G0 X50 Y50 Z5
G1 Z-1 F100
/ G1 X20 Y-5 Z-8
/G91
G1 X10 Y0
M2
"""
EXPECTED = {  # end points, mm, worked out by hand
    True: [(0, 0, 10), (0, 0, -1), (10, 0, -1)],
    False: [(0, 0, 10), (50, 50, 5), (50, 50, -1), (20, -5, -8), (30, -5, -8)],
}
RS274 = shutil.which("rs274")
_MOVE = re.compile(r"STRAIGHT_(?:TRAVERSE|FEED)\(([^)]*)\)")


def _pygcode(text: str, block_delete: bool) -> np.ndarray:
    """End points of the motion blocks (every one of PROGRAM's has its G0/G1), by pygcode's
    machine."""
    from pygcode import GCodeMotion, Line, Machine

    machine, ends = Machine(), []
    for raw in text.splitlines():
        if block_delete and raw.lstrip().startswith("/"):
            continue
        block = Line(raw).block
        machine.process_block(block)
        if any(isinstance(g, GCodeMotion) for g in block.gcodes):
            ends.append(machine.pos.vector.xyz)
    return np.array(ends, dtype=float)


@pytest.mark.parametrize("block_delete", [True, False])
def test_switch_gives_the_expected_moves(block_delete):
    moves = read_gcode_text(PROGRAM, "linuxcnc", block_delete=block_delete)
    assert np.allclose(moves.xyz, EXPECTED[block_delete], atol=1e-9)
    assert np.allclose(moves.xyz, _pygcode(PROGRAM, block_delete), atol=1e-9)
    key = BLOCK_DELETE_SKIPPED if block_delete else BLOCK_DELETE_RUN
    assert moves.other == {key: 3} and moves.blocks == 8  # skipped blocks are read
    assert read_gcode_text(PROGRAM, "linuxcnc").other == {BLOCK_DELETE_SKIPPED: 3}  # default


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is not installed")
@pytest.mark.parametrize("block_delete", [True, False])
def test_switch_agrees_with_rs274(tmp_path, block_delete):
    program = tmp_path / "bd.ngc"
    program.write_text(PROGRAM)
    args = [RS274, *(["-b"] if block_delete else []), "-g", str(program)]
    done = subprocess.run(args, capture_output=True, text=True, stdin=subprocess.DEVNULL,
                          timeout=60, check=True)
    canon = np.array([[float(x) for x in m.group(1).split(",")[:3]]
                      for m in _MOVE.finditer(done.stdout)])
    moves = read_gcode_text(PROGRAM, "linuxcnc", block_delete=block_delete)
    assert canon.shape == moves.xyz.shape and np.allclose(canon, moves.xyz, atol=1e-4)


def test_check_gcode_option_and_summary(tmp_path, capsys):
    program = tmp_path / "bd.ngc"
    program.write_text(PROGRAM)
    said = {}
    for switch in ("on", "off", None):
        out = tmp_path / f"{switch}.json"
        args = ["check-gcode", str(program), "--machine", "linuxcnc-hmc", "--json", str(out)]
        args += [] if switch is None else ["--block-delete", switch]
        with pytest.raises(SystemExit) as ex:
            main(args)
        assert ex.value.code == 0
        said[switch] = (json.loads(out.read_text()), capsys.readouterr().out)
    on, off = said["on"][0], said["off"][0]
    assert on["other"] == {BLOCK_DELETE_SKIPPED: 3} and off["other"] == {BLOCK_DELETE_RUN: 3}
    assert (on["motions"]["motion"], off["motions"]["motion"]) == (3, 5)
    assert said[None][0] == on  # the switch is on unless told
    assert f"{BLOCK_DELETE_SKIPPED} x3" in said["on"][1]
