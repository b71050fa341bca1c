"""The machine check on every real 5-axis program of ../shared/realdata with its machine's
solids (tests/test_machines_realdata.py's list, a 6 mm cutter; the programs come without a
part): the rest of the check (the program as the machine makes it: its poses, the joints the
post would choose, the motion's bookkeeping) and the machine check (`--machine-check`) beside
it, their times and ratio (the machine check is to add at most the check's own time), the
pairs, the exact distances computed, the findings and the least clearance.
Run: `python -m benchmarks.bench_machine`."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.test_machines_realdata import PROGRAMS, REAL  # noqa: E402

_ONE = """
import json, sys, time
from checker.check.options import CheckOptions
from checker.check import check_toolpath
from checker.postproc.machine import load_machine
from checker.postproc.reader import read_gcode
from checker.postproc.replay import part_motions, toolpath_of
from checker.cutter import parse_cutter_in
from checker.stock.request import StockRequest
path, name = sys.argv[1], sys.argv[2]
mach = load_machine(name)
moves = read_gcode(path, mach.dialect, units=mach.units)
motions = part_motions(moves, mach)
cutter = parse_cutter_in("CUTTER/6", moves.units)
tp = toolpath_of(motions, path=path, units=moves.units, cutter=cutter)
t = time.perf_counter()
doc = check_toolpath(tp, options=CheckOptions(cutter=cutter, machine=mach, stock=StockRequest(),
                                             machine_clearance=1.0))
total = time.perf_counter() - t
m = doc.machine
print(json.dumps({"total": total, "poses": doc.summary.poses_checked,
                  "machine_s": None if m is None else m.time_s,
                  "pairs": None if m is None else m.pairs,
                  "distances": None if m is None else m.distances,
                  "findings": None if m is None else len(m.findings),
                  "least": None if m is None or not m.near_misses else m.near_misses[0].least}))
"""


def _run(path: Path, name: str) -> dict:
    out = subprocess.run([sys.executable, "-c", _ONE, str(path), name], capture_output=True,
                         text=True, check=True, cwd=ROOT)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    print(f"{'program':34} {'machine':20} {'poses':>6} {'check s':>8} {'machine s':>9} "
          f"{'ratio':>5} {'pairs':>5} {'distances':>9} {'findings':>8} {'least mm':>9}")
    for rel, name in PROGRAMS:
        path = REAL / rel
        if not path.is_file():
            continue
        got = _run(path, name)
        check = got["total"] - got["machine_s"]
        print(f"{path.name:34} {name:20} {got['poses']:6d} "
              f"{check:8.2f} {got['machine_s']:9.2f} {got['machine_s'] / check:5.2f} "
              f"{got['pairs']:5d} {got['distances']:9d} {got['findings']:8d} "
              f"{got['least']:9.3f}", flush=True)


if __name__ == "__main__":
    main()
