"""CL reader speed: real files from ../shared/realdata (skipped when absent) and a synthetic
100,000-GOTO 5-axis file. Run: `python -m benchmarks.bench_read_cl`."""

from __future__ import annotations

import io
import statistics
import time
from pathlib import Path

import numpy as np

from checker.apt import read_cl, read_cl_text, write_apt

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
FILES = ["mech491-nx-clsf/APT_Project2.txt", "amorim-solidworkscam-apt/boss.apt"]


def synthetic(n: int = 100_000, seed: int = 0) -> str:
    """An APT-CL file with ``n`` 6-value GOTOs (random tips, unit axes), 7 decimals."""
    rng = np.random.default_rng(seed)
    tip = rng.uniform(-100, 100, (n, 3))
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    rows = np.hstack([tip, axis])
    body = "\n".join("GOTO/" + ",".join(f"{v:.7f}" for v in r) for r in rows)
    return f"PARTNO/SYNTH\nUNITS/MM\nCUTTER/10,5\nFEDRAT/1000,MMPM\n{body}\nFINI\n"


def timed(fn, repeat: int) -> tuple[float, float, float]:
    """(best wall, median wall, best CPU) seconds of ``repeat`` calls; the reader is one
    thread, so its CPU time is what the wall time is on an idle machine."""
    wall, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return min(wall), statistics.median(wall), min(cpu)


def main() -> None:
    rows: list[tuple[str, int, int, float, float, float, float]] = []
    cases: list[tuple[str, object]] = []
    for name in FILES:
        p = REALDATA / name
        if p.is_file():
            cases.append((p.name, p))
        else:
            print(f"skipped {name}: {p} not found")
    cases.append(("synthetic 100k GOTO", synthetic()))
    for label, src in cases:
        if isinstance(src, Path):
            size = src.stat().st_size

            def read(src=src):
                return read_cl(src)
        else:
            size = len(src)

            def read(src=src):
                return read_cl_text(src)
        tp = read()  # warm-up (imports, cutter model)
        best, med, cpu = timed(read, 7 if size < 2e6 else 3)
        w_best = timed(lambda tp=tp: write_apt(tp, io.StringIO()), 3)[2]
        rows.append((label, size, len(tp.records), best, med, cpu, w_best))
    print(f"{'file':<22} {'KB':>7} {'records':>8} {'read best s':>11} {'median s':>9} "
          f"{'CPU s':>7} {'records/CPU s':>13} {'write CPU s':>11}")
    for label, size, nrec, best, med, cpu, w in rows:
        print(f"{label:<22} {size / 1024:>7.0f} {nrec:>8} {best:>11.3f} {med:>9.3f} "
              f"{cpu:>7.3f} {nrec / cpu:>13.0f} {w:>11.3f}")


if __name__ == "__main__":
    main()
