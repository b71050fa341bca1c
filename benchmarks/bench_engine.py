"""Allowable-cutter search speed on the mould sample, and the PSO baseline beside it.
Run: `python -m benchmarks.bench_engine [N_PSO]`.

The CC points are the contact points of the mould job's cutting moves (CL -> CC, not timed);
the part is sampled once (not timed). For each cutter: the engine over all CC points (best of
3), then the thesis's PSO + Nelder-Mead baseline on every k-th point (N_PSO points, default 30)
in the same run; accuracy on that subset: how often each method is within 1e-3 mm of the
smaller of the two answers (both only ever report real surface points, so the smaller is the
better), and the largest excess."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from checker.apt import read_cl
from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.geometry import load_part
from checker.geometry.contact import cl_to_cc
from checker.geometry.sampling import sample_part

JOB = Path(__file__).resolve().parents[1] / "samples" / "mould" / "mould.apt"
CUTTERS = ("CUTTER/10,5", "CUTTER/10,2", "CUTTER/10", "CUTTER/9.1633,5,0,5,0,5,0")


def main() -> None:
    n_pso = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    tp = read_cl(JOB)
    ma = tp.motion_arrays()
    cut = ~ma.rapid
    part = load_part(JOB.with_suffix(".json"))
    t = time.perf_counter()
    samples = sample_part(part)
    t_sample = time.perf_counter() - t
    con = cl_to_cc(part, samples, tp.operations[0].cutter, ma.tip[cut], ma.axis[cut])
    cc, nrm, sid, uv = con.cc, con.normal, con.surface, con.uv
    n = len(cc)
    sub = np.linspace(0, n - 1, n_pso).astype(int)
    print(f"mould: {n} CC points, {len(samples.points)} test points (sampled in {t_sample:.2f} s)")
    print(f"{'cutter':28} {'CC/s':>7} {'evals/pt':>9} {'PSO pts':>7} {'PSO s/pt':>9} "
          f"{'PSO ev/pt':>9} {'ratio':>6} {'eng ok':>6} {'PSO ok':>6} {'PSO max excess':>14}")
    for text in CUTTERS:
        c = parse_cutter(text)
        kw = dict(cc_surface=sid, cc_uv=uv)
        allowable(samples, part, c, cc[:8], nrm[:8], cc_surface=sid[:8], cc_uv=uv[:8])  # compile
        runs = []
        for _ in range(3):
            t = time.perf_counter()
            res = allowable(samples, part, c, cc, nrm, **kw)
            runs.append(time.perf_counter() - t)
        rate = n / min(runs)
        t = time.perf_counter()
        pso = allowable(samples, part, c, cc[sub], nrm[sub], method="pso", seed=1,
                        cc_surface=sid[sub], cc_uv=uv[sub])
        t_pso = (time.perf_counter() - t) / len(sub)
        e, p = res.size[sub], pso.size
        best = np.minimum(e, p)
        fin = np.isfinite(best)
        gap_e = np.where(fin, np.nan_to_num(e - np.where(fin, best, 0.0), posinf=1e9), 0.0)
        gap_p = np.where(fin, np.nan_to_num(p - np.where(fin, best, 0.0), posinf=1e9), 0.0)
        eng_ok, pso_ok = np.mean(gap_e <= 1e-3), np.mean(gap_p <= 1e-3)
        excess = float(gap_p.max())
        print(f"{text:28} {rate:7.0f} {res.evaluations.mean():9.0f} {len(sub):7d} "
              f"{t_pso:9.4f} {pso.evaluations.mean():9.0f} {t_pso * rate:6.0f} "
              f"{eng_ok:6.0%} {pso_ok:6.0%} {excess:14.4f}")


if __name__ == "__main__":
    main()
