"""The engine against the brute-force oracle (tests/engine_oracle.py) on every CC point of the
mould job's cutting moves, not only on the test suite's random sample points.
Run: `python -m benchmarks.engine_job_oracle [CUTTER ...] [--dense N]` (default: ball,
bull-nose and flat, dense 150; about 1-2 min per cutter on 2 cores).

Prints per cutter how many rows the engine is above the oracle (it would call a cutter safe
that is not) by more than 1e-3, 1e-2 and 0.1 mm, the largest such excess and its rows, and how
many rows the engine is lower (the oracle's grids miss the minimum)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from checker.cutter import parse_cutter
from checker.engine import allowable

ROOT = Path(__file__).resolve().parents[1]
JOB = ROOT / "samples" / "mould" / "mould.apt"
CUTTERS = ("CUTTER/10,5", "CUTTER/10,2", "CUTTER/10")


def main() -> None:
    sys.path.insert(0, str(ROOT / "tests"))
    from engine_oracle import oracle_sizes
    from job_contacts import job_contacts

    args = sys.argv[1:]
    dense = 150
    if "--dense" in args:
        k = args.index("--dense")
        dense = int(args[k + 1])
        del args[k:k + 2]
    part, samples, con = job_contacts(JOB)
    kw = dict(cc_surface=con.surface, cc_uv=con.uv)
    print(f"mould: {len(con.cc)} CC points, oracle dense {dense}")
    for text in args or CUTTERS:
        c = parse_cutter(text)
        eng = allowable(samples, part, c, con.cc, con.normal, **kw).size
        ref = oracle_sizes(part, c, con.cc, con.normal, dense=dense, **kw)
        both = np.isfinite(eng) & np.isfinite(ref)
        d = np.where(both, eng - np.where(both, ref, 0.0), 0.0)
        worst = np.argsort(-d)[:5]
        print(f"{text:28} above by >1e-3: {(d > 1e-3).sum():3d}  >1e-2: {(d > 1e-2).sum():3d}  "
              f">0.1: {(d > 0.1).sum():3d}  max {d.max():.3g} mm (rows {worst.tolist()})  "
              f"below by >1e-3: {(d < -1e-3).sum():3d}  finite differ: "
              f"{(np.isfinite(eng) != np.isfinite(ref)).sum()}")


if __name__ == "__main__":
    main()
