"""Memory and time of large inputs: generates CL programs of 1 M, 5 M and 10 M moves and a CSV
of 1 M CC points in a scratch folder, runs `pathcheck info`, a check and `pathcheck allowable --cc`
on them under `/usr/bin/time -v` and prints peak RSS and wall time (the job-size table of
docs/benchmarks.md).

Run: `python -m benchmarks.bench_large [--moves 1e6,5e6,10e6] [--cc 1e6] [--check 1e6]
[--dir /tmp/pathcheck-large]`. The files are written in chunks (no program is held in memory).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MOULD = ROOT / "samples" / "mould"
CHUNK = 200_000


def write_cl(path: Path, moves: int, *, seed: int = 0) -> Path:
    """An APT-CL program of ``moves`` GOTOs over the mould sample's box, 4 decimals: a zigzag
    raster at 0.05 mm steps 1 mm above the mould's top (clean for the mould's D10 ball), every
    tenth move with a tool axis (the 6-value form). Written in chunks of CHUNK lines."""
    rng = np.random.default_rng(seed)
    with path.open("w") as fh:
        fh.write("PARTNO/LARGE\nUNITS/MM\nCUTTER/10,5\nLOADTL/1\nSPINDL/10000,RPM,CLW\n"
                 "RAPID\nGOTO/-60.0000,-35.0000,40.0000\nFEDRAT/800.0,MMPM\n")
        done = 0
        while done < moves:
            n = min(CHUNK, moves - done)
            k = np.arange(done, done + n)
            row, col = np.divmod(k, 2400)
            x = np.where(row % 2 == 0, col, 2399 - col) * 0.05 - 60.0
            y = (row % 1400) * 0.05 - 35.0
            z = 40.0 + 1e-4 * rng.integers(0, 10, n)
            lines = [f"GOTO/{a:.4f},{b:.4f},{c:.4f}" for a, b, c in zip(x, y, z, strict=True)]
            for j in range(0, n, 10):
                lines[j] += ",0.000000,0.000000,1.000000"
            fh.write("\n".join(lines))
            fh.write("\n")
            done += n
        fh.write("FINI\n")
    return path


def write_cc(path: Path, rows: int) -> Path:
    """A CSV of ``rows`` CC points x,y,z,nx,ny,nz: the mould sample's cc.csv repeated."""
    src = (MOULD / "cc.csv").read_text().splitlines()
    body = [s for s in src[1:] if s.strip()]
    with path.open("w") as fh:
        fh.write(src[0] + "\n")
        done = 0
        while done < rows:
            n = min(CHUNK, rows - done)
            fh.write("\n".join(body[(done + j) % len(body)] for j in range(n)))
            fh.write("\n")
            done += n
    return path


_RSS = re.compile(r"Maximum resident set size \(kbytes\): (\d+)")
_WALL = re.compile(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)")


def measure(args: list[str]) -> tuple[float, float, int, str]:
    """(peak RSS MB, wall s, exit code, its last error line) of `pathcheck ARGS` under
    /usr/bin/time -v."""
    cmd = ["/usr/bin/time", "-v", sys.executable, "-m", "checker.cli", *args]
    run = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=os.environ.copy())
    rss = int(_RSS.search(run.stderr).group(1)) / 1024
    h, m, s = _WALL.search(run.stderr).groups()
    wall = int(h or 0) * 3600 + int(m) * 60 + float(s)
    said = [s for s in run.stderr.splitlines() if s.startswith("pathcheck:")]
    return rss, wall, run.returncode, (said[-1] if said else "")


def _counts(text: str) -> list[int]:
    return [int(float(s)) for s in text.split(",") if s.strip()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", default="1e6,5e6,10e6", help="program sizes for info")
    ap.add_argument("--check", default="1e6,10e6", help="program sizes to check against the mould")
    ap.add_argument("--cc", default="1e6", help="CC-point counts for allowable --cc")
    ap.add_argument("--dir", type=Path, default=Path("/tmp/pathcheck-large"))
    a = ap.parse_args()
    a.dir.mkdir(parents=True, exist_ok=True)
    shutil.copy(MOULD / "mould.json", a.dir / "mould.json")
    print("| input | command | peak RSS MB | wall s | exit |")
    print("|---|---|---:|---:|---|")
    for n in sorted(set(_counts(a.moves)) | set(_counts(a.check))):
        cl = write_cl(a.dir / f"large_{n}.apt", n)
        size = cl.stat().st_size / 1e6
        runs = []
        if n in _counts(a.moves):
            runs.append(("info", ["info", str(cl)]))
        if n in _counts(a.check):
            runs.append(("check", [str(cl), "--part", str(a.dir / "mould.json"), "--no-store"]))
        for label, args in runs:
            rss, wall, rc, tail = measure(args)
            print(f"| {n:,} moves ({size:.0f} MB) | {label} | {rss:,.0f} | {wall:.1f} | {rc} "
                  f"{tail[:80]} |", flush=True)
        cl.unlink()
    for n in _counts(a.cc):
        cc = write_cc(a.dir / f"cc_{n}.csv", n)
        rss, wall, rc, tail = measure(["allowable", "--part", str(MOULD / "mould.json"),
                                       "--cc", str(cc), "--cutter", "CUTTER/10,5"])
        print(f"| {n:,} CC rows | allowable --cc | {rss:,.0f} | {wall:.1f} | {rc} {tail[:80]} |",
              flush=True)
        cc.unlink()


if __name__ == "__main__":
    main()
