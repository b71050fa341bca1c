"""Nightly report speed. Run: `python -m benchmarks.bench_report [JOBS]`.

Records JOBS (default 200) synthetic jobs of 41 x 41 CC points (a mould raster, ball cutter,
two thirds 4-axis, 1 in 25 failed) into a fresh store within the last night, then builds the
report from cold: page, 4 pictures per job, trends, JSON and CSV; with the configured picture
processes and with one. The issue asks for under 10 s over 200 jobs. `cpu s` is the CPU time
of the build (all processes): on a busy machine it is the better guide to a quiet one.
"""

from __future__ import annotations

import resource
import sys
import tempfile
import time
from pathlib import Path

from checker.config import default_config
from checker.report import build_report
from checker.store import ResultsStore
from tests.synthetic_results import synthetic_document


def _cpu_s() -> float:
    """CPU seconds of this process and its finished children (the picture processes)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(
        resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main(jobs: int = 200) -> None:
    cfg = default_config()
    docs = [synthetic_document(k, n=41, four_axis=k % 3 != 0) for k in range(10)]
    now = time.time()
    with tempfile.TemporaryDirectory() as tmp, ResultsStore(Path(tmp) / "bench.sqlite") as store:
        start = time.perf_counter()
        for i in range(jobs):
            t = now - 3600.0 - 60.0 * i
            if i % 25 == 24:
                store.record_job(None, error=f"jobs/{i}.apt:1: expected PARTNO",
                                 job_path=f"jobs/{i}.apt", elapsed_s=0.1, recorded_at=t)
            else:
                store.record_job(docs[i % 10], elapsed_s=1.0, recorded_at=t,
                                 job_path=f"jobs/{i}.apt")
        record_s = (time.perf_counter() - start) / jobs
        print(f"{'jobs':>5} {'points/job':>10} {'record ms/job':>13} {'workers':>7} "
              f"{'pictures':>8} {'report s':>8} {'cpu s':>6} {'page MB':>7}")
        for workers in (cfg.report.render_workers, 1):
            config = cfg.model_copy(
                update={"report": cfg.report.model_copy(update={"render_workers": workers})}
            )
            start, cpu = time.perf_counter(), _cpu_s()
            files = build_report(store, Path(tmp) / "report.html", now=now, config=config)
            took, cpu = time.perf_counter() - start, _cpu_s() - cpu
            size = files.html.stat().st_size / 1e6
            print(f"{files.jobs:5d} {41 * 41:10d} {1e3 * record_s:13.1f} {workers:7d} "
                  f"{files.pictures:8d} {took:8.2f} {cpu:6.2f} {size:7.1f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
