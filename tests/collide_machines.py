"""Machines and programs for the machine-check tests: a shipped machine file with its
components replaced, written beside a G-code program, and the check run through the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from checker.cli import main
from checker.resources import resource


def machine_file(tmp: Path, shipped: str, components: str, extra: str = "") -> Path:
    """A copy of the shipped machine `shipped` with `components` (TOML `[[components]]` text)
    instead of its own, top-level keys `extra` first; written in `tmp`."""
    text = (resource("machines") / f"{shipped}.toml").read_text()
    text = text.split("\n[[components]]", 1)[0]
    text = "\n".join(line for line in text.splitlines()
                     if not line.startswith("components_source"))
    head, _, rest = text.partition("\n[")
    path = tmp / f"{shipped}-test.toml"
    path.write_text(f"{head}\n{extra}\n[{rest}\n\n{components}\n")
    return path


def check(tmp: Path, machine: Path, program: str, *args: str) -> dict:
    """The results document of `check-gcode` on `program` (G-code text) with the machine
    check; the exit code is 0 or 1."""
    prog = tmp / "prog.ngc"
    prog.write_text(program)
    out = tmp / "out.json"
    with pytest.raises(SystemExit) as ex:
        main(["check-gcode", str(prog), "--machine", str(machine), "--cutter", "CUTTER/6",
              "--machine-check", "--json", str(out), "--no-store", *args])
    assert ex.value.code in (0, 1)
    return json.loads(out.read_text())


# A 3-axis CL job on the head-head machine with the nose and the block of
# tests/test_collide_head.py: at words 0 the spindle nose is 100 mm (the machine's tool length)
# above the tip, so its face is over the block's top (91.15) by Z + 8.85; with the clearance
# 0.5 mm a contact starts where the tip comes down through Z = 0.5 - 8.85 = -8.35, on the
# descent of line 7, lasts through line 8 at Z -20 (11.15 mm into the block) and ends on the
# climb of line 9 (the contact's start is found to 0.005 mm of travel, `RESOLUTION`). The
# part is a plate far below the path (no other finding).
DESCENT_Z = 0.5 - (100.0 - 91.15)
DESCENT_LEAST = -20.0 + (100.0 - 91.15)
DESCENT = """PARTNO/DESCENT
UNITS/MM
CUTTER/6
RAPID
GOTO/0,0,20
FEDRAT/1000,MMPM
GOTO/0,0,-20
GOTO/10,0,-20
GOTO/10,0,20
"""


def descent_job(folder: Path, *, part: bool = True) -> tuple[Path, Path]:
    """The descent job (`DESCENT`) as `descent.apt` in `folder`, its plate part beside it as
    `descent.stl` (with `part`), and the head-head machine with the nose and the block as
    `head.toml`: (job, machine)."""
    from test_collide_head import NOSE
    from vise import write_boxes

    folder.mkdir(parents=True, exist_ok=True)
    job = folder / "descent.apt"
    job.write_text(DESCENT)
    if part:
        write_boxes(folder / "descent.stl", [((-30.0, -30.0, -80.0), (40.0, 30.0, -60.0))])
    machine = machine_file(folder, "linuxcnc-head-head-ac", NOSE).rename(folder / "head.toml")
    return job, machine


def the_descent_finding(machine_doc: dict) -> dict:
    """The one machine finding of the descent job, checked against the closed form."""
    (f,) = machine_doc["findings"]
    assert (f["a"], f["b"], f["line"]) == ("block", "nose", 7), f
    assert abs(f["axes"]["Z"] - DESCENT_Z) < 0.01, (f["axes"], DESCENT_Z)
    assert abs(f["distance"] - DESCENT_LEAST) < 1e-3, f
    assert f["poses"] == 3  # lines 7 and 8, and the climb of line 9 starts in contact
    return f
