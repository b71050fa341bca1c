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
