"""Every real 5-axis program of ../shared/realdata checked with its machine's solids
(`check-gcode --machine-check`, a 6 mm cutter): no error, a machine section with every pair's
least clearance (printed), and on the impeller (the LinuxCNC trunnion A/C, its tool far from the
generic table) no machine collision."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from requires import require_extra
from test_machines_realdata import PROGRAMS, _program

from checker.cli import main

require_extra("coal", "machine")


@pytest.mark.parametrize(("rel", "name"), PROGRAMS, ids=[Path(p).stem for p, _ in PROGRAMS])
def test_realdata_program_with_its_machine(rel, name, tmp_path, capsys):
    path = _program(rel)
    out = tmp_path / "out.json"
    with pytest.raises(SystemExit) as ex:
        main(["check-gcode", str(path), "--machine", name, "--cutter", "CUTTER/6",
              "--machine-check", "--json", str(out), "--no-store"])
    assert ex.value.code in (0, 1)
    doc = json.loads(out.read_text())
    m = doc["machine"]
    assert m["machine"] == name and m["pairs"] > 0 and m["source"].startswith("generic")
    assert len(m["near_misses"]) == m["pairs"]
    leasts = [p["least"] for p in m["near_misses"]]
    assert leasts == sorted(leasts)
    if m["findings"]:
        assert doc["summary"]["status"] == "findings"
        assert all(f["distance"] < m["clearance"] for f in m["findings"])
    with capsys.disabled():
        found = (f"{len(m['findings'])} machine collision(s), first line "
                 f"{m['findings'][0]['line']}" if m["findings"] else "no machine collision")
        print(f"\n{Path(rel).name} on {name}: {found}; {m['time_s']:.2f} s, "
              f"{m['distances']} distances")
        for p in m["near_misses"][:4]:
            print(f"  {p['a']} / {p['b']}: {p['least']:.3f} mm at line {p['line']}")
    if rel.endswith("impeller-7bl-xyzac.ngc"):
        assert m["findings"] == [] and leasts[0] > m["clearance"]
