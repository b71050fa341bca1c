"""`allowable` on rows with their own tool axes: rows/s on the compressor sample (4-axis job,
ball CUTTER/6,3) with one shared axis, with the CAM's axes (all different), with (CC point, B)
pairs at random B as in the best-B search, and one call per axis (the cost of an axis of its
own, as before axis bins). Run: `python -m benchmarks.bench_engine_axes [REPEATS]`.

CC points: the contact points of the job's cutting moves (CL -> CC, not timed); the part is
sampled once (not timed). Best of REPEATS (default 2) wall-clock runs; `per CPU s` divides by
the process CPU time of that run (less sensitive to other load on the machine)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from benchmarks.timing import best_of
from checker.apt import read_cl
from checker.b_axis import axis_for_b
from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.geometry import load_part
from checker.geometry.contact import cl_to_cc
from checker.geometry.sampling import sample_part

JOB = Path(__file__).resolve().parents[1] / "samples" / "compressor" / "compressor.apt"
CUTTER = "CUTTER/6,3"
B_PAIRS = 6  # random B values per CC point in the best-B case
PER_AXIS_ROWS = 60  # rows timed one call each


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    ma = read_cl(JOB).motion_arrays()
    cut = ~ma.rapid
    part = load_part(JOB.with_suffix(".json"))
    tp = sample_part(part)
    c = parse_cutter(CUTTER)
    con = cl_to_cc(part, tp, c, ma.tip[cut], ma.axis[cut])
    axes = ma.axis[cut]
    n = len(con.cc)
    n_axes = len(np.unique(np.round(axes, 12), axis=0))
    print(f"compressor: {n} CC points ({n_axes} distinct axes), {len(tp.points)} test points, "
          f"{CUTTER}")
    rng = np.random.default_rng(1)
    pair = np.tile(np.arange(n), B_PAIRS)
    one = np.linspace(0, n - 1, PER_AXIS_ROWS).astype(int)

    def run(idx, ax):
        return lambda: allowable(tp, part, c, con.cc[idx], con.normal[idx], ax,
                                 cc_surface=con.surface[idx], cc_uv=con.uv[idx])

    def per_axis():
        for i in one:
            run([i], axes[[i]])()

    all_rows = np.arange(n)
    cases = [
        ("one shared axis (B = 10)", n, run(all_rows, axis_for_b(np.full(n, 10.0)))),
        ("CAM axes, all distinct", n, run(all_rows, axes)),
        (f"{B_PAIRS} random B per point", pair.size,
         run(pair, axis_for_b(rng.uniform(-30.0, 30.0, pair.size)))),
        ("one call per axis", len(one), per_axis),
    ]
    run(all_rows[:8], axes[:8])()  # compile
    print(f"{'case':28} {'rows':>7} {'best s':>7} {'rows/s':>7} {'per CPU s':>9}")
    for name, rows, fn in cases:
        wall, _, cpu = best_of(fn, repeats)
        print(f"{name:28} {rows:7d} {wall:7.2f} {rows / wall:7.0f} {rows / cpu:9.0f}")


if __name__ == "__main__":
    main()
