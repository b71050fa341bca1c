"""Feasible tool orientations per CC point (`checker.five_axis.feasible_region`): CC points per
second on the channel part (tests/five_axis_parts.py) and on `samples/impeller` when present
(its cc.csv). Run: `python -m benchmarks.bench_feasible`. Grid 5 degrees over lead and tilt in
[-60, 60] (625 poses), boundary to 0.01 degrees; bull-nose D8 r1 with shank and holder; one
warm-up call, then the best of 2 runs."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
IMPELLER = ROOT / "samples" / "impeller"


def _cases():
    from five_axis_parts import channel, channel_contacts

    from checker.config import default_config
    from checker.geometry.tessellate import part_triangles

    geo = default_config().geometry
    cc, n, f = channel_contacts(40)
    yield "channel", part_triangles(channel(), 0.001, geo), cc, n, f
    if IMPELLER.is_dir():
        from checker.geometry import load_part

        part = sorted(IMPELLER.glob("*.json")) + sorted(IMPELLER.glob("*.stl"))
        rows = np.loadtxt(IMPELLER / "cc.csv", delimiter=",", skiprows=1)
        pick = np.linspace(0, len(rows) - 2, min(40, len(rows) - 1)).astype(int)
        yield ("impeller", part_triangles(load_part(part[0]), 0.001, geo), rows[pick, :3],
               rows[pick, 3:6], rows[pick + 1, :3] - rows[pick, :3])


def rate(judge, cc, n, f, runs: int = 2, **kw):
    """(region, CC points per second): `feasible_region` after a warm-up call on two points,
    the best of `runs` runs; `kw` its options (grid, limits, tolerance, machine)."""
    from checker.five_axis.feasible import feasible_region

    feasible_region(judge, cc[:2], n[:2], f[:2], **kw)
    best = np.inf
    for _ in range(runs):
        t = time.perf_counter()
        reg = feasible_region(judge, cc, n, f, **kw)
        best = min(best, time.perf_counter() - t)
    return reg, len(cc) / best


def main() -> None:
    from five_axis_parts import tool

    from checker.five_axis.poses import PoseJudge

    cutter = tool("CUTTER/8,1", 12.0, 8.0, 30.0, 24.0, 30.0)
    print(f"{'part':10} {'triangles':>9} {'CC':>4} {'feasible':>8} {'edges':>6} {'CC/s':>7}")
    for name, tri, cc, n, f in _cases():
        judge = PoseJudge.for_triangles(tri, cutter, 0.01)
        reg, per_s = rate(judge, cc, n, f)
        print(f"{name:10} {len(tri.triangles):9d} {len(cc):4d} {reg.mask.mean():8.1%} "
              f"{len(reg.crossing):6d} {per_s:7.1f}")


if __name__ == "__main__":
    main()
