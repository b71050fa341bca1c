"""Imaginary-cutter kernel speed. Run: `python -m benchmarks.bench_kernels`.

Pairs (test point, CC point) per second, for each cutter kind, through `Cutter.imaginary_size`
on K independent pairs (K,3 arrays; parallel kernel above 20,000 pairs), and the numba thread
count used. Random CC points, normals and test points around them (mm); compile time excluded
(one warm-up call), best of 3 runs.
"""

from __future__ import annotations

import numba
import numpy as np

from benchmarks.timing import best_of
from checker.cutter import parse_cutter

CUTTERS = {
    "flat": "CUTTER/10",
    "bullnose": "CUTTER/12,2",
    "apt": "CUTTER/8.787953233572349,1.5,3.0,2.0521208599540124,10.0,5.0,60.0",
    "ball": "CUTTER/10,5",
    "tapered_ball": "CUTTER/9.1633,5,0,5,0,5,60",
}
K = 2_000_000  # independent pairs


def _normals(rng, m: int) -> np.ndarray:
    nz = rng.uniform(0.2, 1.0, m)
    a = rng.uniform(0, 2 * np.pi, m)
    h = np.sqrt(1 - nz**2)
    return np.stack([h * np.cos(a), h * np.sin(a), nz], axis=1)


def main() -> None:
    rng = np.random.default_rng(0)
    p = rng.uniform(-15, 15, (K, 3))
    cc = rng.uniform(-1, 1, (K, 3))
    n = _normals(rng, K)
    print(f"numba threads: {numba.get_num_threads()}  pairs: {K:,} independent")
    print(f"{'cutter':<14}{'pairs':>12}   (pairs per second)")
    for kind, text in CUTTERS.items():
        c = parse_cutter(text)
        t_pairs = best_of(lambda c=c: c.imaginary_size(p, cc, n), warm=True).wall
        print(f"{kind:<14}{K / t_pairs / 1e6:>12.1f} M")


if __name__ == "__main__":
    main()
