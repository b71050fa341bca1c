"""The 4-axis job end to end on the compressor sample (2 blade surfaces x 41 x 41 CC points as
in thesis chapter 5): CL -> CC, the allowable size at the CAM's B, the best-B search over the
machine's range with feasible intervals, the orientation along the path (shortest path and
greedy), the real tool checked along the written program's moves, and the corrected G-code.
Run: `python -m benchmarks.bench_four_axis [JOB.apt]`."""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.config import default_config

JOB = Path(__file__).resolve().parents[1] / "samples" / "compressor" / "compressor.apt"


def main() -> None:
    job = Path(sys.argv[1]) if len(sys.argv) > 1 else JOB
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        cfg = default_config()  # with the greedy smoothing of Jun, Lee and Cha (2002) to compare
        cfg = cfg.model_copy(update={"four_axis": cfg.four_axis.model_copy(
            update={"greedy_baseline": True})})
        doc = check_job(job, options=CheckOptions(output=Path(tmp) / "out.nc",
                                                 on_findings="comment", config=cfg))
        wall = time.perf_counter() - t
    s, o = doc.summary, doc.orientation
    print(f"{job.name}: {s.cl_points} poses at CL records, {s.poses_checked} poses checked "
          f"along the moves, {doc.job.axis_class}")
    print(f"  wall time (check + best B + orientation + moves + G-code): {wall:.1f} s")
    print(f"  CL poses/s over the whole job: {s.cl_points / wall:.0f}")
    print(f"  verdicts of the written program: {s.counts.model_dump()}")
    if s.counts_cam is not None:
        print(f"  verdicts at the CAM's B: {s.counts_cam.model_dump()}")
    if o is not None:
        print(f"  rotary motion: shortest path {o.dp_total_rotation:.1f} deg, greedy "
              f"{o.greedy_total_rotation:.1f} deg, CAM {o.original_total_rotation:.1f} deg; "
              f"{o.infeasible_points} points without a feasible B")


if __name__ == "__main__":
    main()
