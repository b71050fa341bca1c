"""CL -> CC speed on the bundled sample jobs. Run: `python -m benchmarks.bench_contact`.

For each sample: read the job, load and sample the part (cached after the first run, not
timed), then `cl_to_cc` over every cutting move (F800; the plunges at F250 stop 5 mm short);
best and median of 3 runs, and the largest |gap| (the files carry 4 decimals: about 1e-4 mm).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

from checker.apt import read_cl
from checker.geometry import load_part
from checker.geometry.contact import cl_to_cc
from checker.geometry.sampling import sample_part

SAMPLES = Path(__file__).resolve().parents[1] / "samples"
JOBS = ("compressor/compressor.apt", "mould/mould.apt")


def main() -> None:
    print(f"{'job':32} {'CL points':>9} {'test pts':>9} {'best s':>8} {'median s':>8} "
          f"{'CL/s':>8} {'max |gap| mm':>12}")
    for name in JOBS:
        job = SAMPLES / name
        tp = read_cl(job)
        ma = tp.motion_arrays()
        cut = ~ma.rapid & (ma.feed == 800.0)
        part = load_part(job.with_suffix(".json"))
        points = sample_part(part)
        cutter = tp.operations[0].cutter
        runs, gap = [], 0.0
        for _ in range(3):
            t = time.perf_counter()
            got = cl_to_cc(part, points, cutter, ma.tip[cut], ma.axis[cut])
            runs.append(time.perf_counter() - t)
            gap = float(np.abs(got.gap).max())
        n = int(cut.sum())
        print(f"{name:32} {n:9d} {len(points.points):9d} {min(runs):8.3f} "
              f"{statistics.median(runs):8.3f} {n / min(runs):8.0f} {gap:12.2e}")


if __name__ == "__main__":
    main()
