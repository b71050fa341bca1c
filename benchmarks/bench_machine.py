"""The machine check on every real 5-axis program of ../shared/realdata with its machine's
solids (tests/test_machines_realdata.py's list, a 6 mm cutter): the check of the program
(`check-gcode` against a box stock around the program's tips at 1 mm rays, no part) and the machine check
(`--machine-check`) beside it, their times, the pairs, the exact distances computed and the
findings. Run: `python -m benchmarks.bench_machine`."""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.test_machines_realdata import PROGRAMS, REAL  # noqa: E402

_ONE = """
import json, sys, time
from checker.job import check_toolpath
from postproc.machine import load_machine
from postproc.reader import read_gcode
from postproc.replay import part_motions, toolpath_of
from checker.cutter import parse_cutter_in
from checker.stock.request import StockRequest
path, name, machine_check = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
mach = load_machine(name)
moves = read_gcode(path, mach.dialect, units=mach.units)
motions = part_motions(moves, mach)
cutter = parse_cutter_in("CUTTER/6", moves.units)
tp = toolpath_of(motions, path=path, units=moves.units, cutter=cutter)
import numpy as np
tips = motions.tip[motions.known]
lo, hi = tips.min(axis=0) - 5.0, tips.max(axis=0) + 5.0
box = "box:" + ",".join(f"{v:.3f}" for v in (*lo, *hi))
t = time.perf_counter()
doc = check_toolpath(tp, cutter=cutter, machine=mach, stock=StockRequest(box, resolution=1.0),
                     machine_clearance=1.0 if machine_check else None)
total = time.perf_counter() - t
m = doc.machine
print(json.dumps({"total": total, "poses": doc.summary.poses_checked,
                  "machine_s": None if m is None else m.time_s,
                  "pairs": None if m is None else m.pairs,
                  "distances": None if m is None else m.distances,
                  "findings": None if m is None else len(m.findings),
                  "least": None if m is None or not m.near_misses else m.near_misses[0].least}))
"""


def _run(path: Path, name: str, machine_check: bool) -> dict:
    out = subprocess.run([sys.executable, "-c", _ONE, str(path), name,
                          "1" if machine_check else "0"], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    print(f"{'program':34} {'machine':20} {'poses':>6} {'check s':>8} {'machine s':>9} "
          f"{'pairs':>5} {'distances':>9} {'findings':>8} {'least mm':>9}")
    with tempfile.TemporaryDirectory():
        for rel, name in PROGRAMS:
            path = REAL / rel
            if not path.is_file():
                continue
            base = _run(path, name, False)
            got = _run(path, name, True)
            print(f"{path.name:34} {name:20} {got['poses']:6d} {base['total']:8.2f} "
                  f"{got['machine_s']:9.2f} {got['pairs']:5d} {got['distances']:9d} "
                  f"{got['findings']:8d} {got['least']:9.3f}")


if __name__ == "__main__":
    main()
