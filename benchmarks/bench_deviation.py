"""The machined part against the design (checker/machined, docs/MATH.md §15) beside the stock
simulation it compares: the amorim Interface-glue job against a box 3 mm around its STL at
h = 0.05 mm (`--stock box:+3 --stock-resolution 0.05`), in process. Prints the simulation's
own time (the stock stage less the comparison), the comparison's (the measuring mesh, the
deviation after each operation and at the end, the regions and the advice) and what it found.

    python -m benchmarks.bench_deviation [resolution]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.stock.request import StockRequest

JOB = (Path(__file__).resolve().parents[2] / "shared" / "realdata" / "amorim-solidworkscam-apt"
       / "Interface-glue.apt")


def main(argv: list[str]) -> None:
    if not JOB.is_file():
        print(f"{JOB.name}: not found")
        return
    h = float(argv[0]) if argv else 0.05
    t0 = time.perf_counter()
    doc = check_job(JOB, options=CheckOptions(stock=StockRequest("box:+3", resolution=h)))
    wall = time.perf_counter() - t0
    st, m = doc.stock, doc.stock.machined
    simulation = st.time_s - m.time_s
    print(f"{JOB.name} --stock box:+3 at {h:g} mm: check {wall:.1f} s in all; the stock "
          f"simulation {simulation:.1f} s, the comparison {m.time_s:.1f} s "
          f"({m.time_s / simulation:.2f} x the simulation) over {m.points:,} points at "
          f"{m.spacing:.3f} mm after each of {len(m.operations)} operations; over-cut up to "
          f"{m.overcut_max:.3f} mm ({m.gouge_points:,} points, {len(m.overcut)} regions), left "
          f"up to {m.left_max:.3f} mm; {m.advice}")


if __name__ == "__main__":
    main(sys.argv[1:])
