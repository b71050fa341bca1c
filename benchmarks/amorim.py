"""Every amorim SolidWorks-CAM job with an STL (../shared/realdata/amorim-solidworkscam-apt):
pathcheck's whole check (`check_job`, warm kernel cache) in a fresh process, its wall time and
peak memory, and the OpenCAMLib oracle at the same poses beside it (tests/amorim_jobs.py).
Run: `python -m benchmarks.amorim`."""

from __future__ import annotations

import json
import resource
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from amorim_jobs import AMORIM, JOBS, compare  # noqa: E402

_ONE_JOB = """
import json, resource, sys, time
from checker.check import check_job
t = time.perf_counter()
doc = check_job(sys.argv[1])
print(json.dumps({"seconds": time.perf_counter() - t, "status": doc.summary.status,
                  "poses": doc.summary.cl_points, "moves": doc.summary.move_points,
                  "checked": doc.summary.poses_checked,
                  "findings": sum(p.verdict in ("gouge", "interference", "holder", "crash")
                                  for p in doc.points)}))
"""


def _isolated(job: str) -> dict:
    """The check in its own process: its wall time and its peak resident memory (MB)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    out = subprocess.run([sys.executable, "-c", _ONE_JOB, str(AMORIM / f"{job}.apt")],
                         capture_output=True, text=True, check=True, cwd=ROOT)
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    got = json.loads(out.stdout.strip().splitlines()[-1])
    got["peak_mb"] = max(peak, before) / 1024.0
    return got


def main() -> None:
    print(f"{'job':22} {'poses':>6} {'moves':>6} {'checked':>8} {'findings':>8} {'s':>6} "
          f"{'peak MB':>8} {'oracle s':>8} {'compared':>8} {'both':>6} {'oracle only':>11} "
          f"{'ours only':>9} {'max |dd|':>9}")
    for job in JOBS:
        run = _isolated(job)
        c = compare(job)
        print(f"{job:22} {run['poses']:6d} {run['moves']:6d} {run['checked']:8d} "
              f"{run['findings']:8d} {run['seconds']:6.1f} {run['peak_mb']:8.0f} "
              f"{c.oracle_seconds:8.1f} {c.compared:8d} {c.both:6d} {len(c.oracle_only):11d} "
              f"{len(c.pathcheck_only):9d} {c.max_depth_difference:9.1e}")


if __name__ == "__main__":
    main()
