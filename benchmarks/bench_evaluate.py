"""Surface evaluation and part loading speed. Run: `python -m benchmarks.bench_evaluate`.

- points + unit normals per second on a rational degree-5 patch (8 x 8 poles), 1,000,000
  random (u, v), against geomdl's own per-point evaluation on a small subset;
- order-2 evaluation (principal curvatures) and `evaluate_mixed` over 50 surfaces;
- STEP loading (ec_turbine-A.stp, 53 faces) and test-point sampling, when ../shared is present.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from geomdl import NURBS

from benchmarks.timing import best_of
from checker.geometry.evaluate import evaluate, evaluate_mixed, principal_curvatures
from checker.part import Part, Surface

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
N = 1_000_000


def degree5_patch(seed: int = 0, n: int = 8) -> Surface:
    """A rational degree-5 x 5 patch with n x n random poles (mm) and interior knots."""
    rng = np.random.default_rng(seed)
    k = np.r_[np.zeros(6), np.linspace(0, 1, n - 4)[1:-1], np.ones(6)]
    grid = np.stack(np.meshgrid(np.linspace(0, 100, n), np.linspace(0, 80, n), indexing="ij"), -1)
    ctrl = np.concatenate([grid, rng.normal(scale=5.0, size=(n, n, 1))], axis=2)
    return Surface(0, "patch", "nurbs", 5, 5, k, k, ctrl, rng.uniform(0.6, 1.6, (n, n)))


def geomdl_rate(s: Surface, u, v) -> float:
    g = NURBS.Surface()
    g.degree_u, g.degree_v = 5, 5
    g.ctrlpts_size_u, g.ctrlpts_size_v = s.ctrlpts.shape[:2]
    g.ctrlpts = s.ctrlpts.reshape(-1, 3).tolist()
    g.weights = s.weights.ravel().tolist()
    g.knotvector_u, g.knotvector_v = s.knots_u.tolist(), s.knots_v.tolist()
    t = time.perf_counter()
    for a, b in zip(u, v, strict=True):
        d = g.derivatives(a, b, 1)  # what geomdl's normal() does per point
        n = np.cross(d[1][0], d[0][1])
        n /= np.linalg.norm(n)
    return len(u) / (time.perf_counter() - t)


def main() -> None:
    import numba

    s = degree5_patch()
    rng = np.random.default_rng(1)
    u, v = rng.uniform(0, 1, N), rng.uniform(0, 1, N)
    evaluate(s, u[:10], v[:10])  # compile / load the cache outside the timing
    principal_curvatures(s, u[:10], v[:10])
    rows = []
    rows.append(("points + normals, degree 5x5 rational", N,
                 *best_of(lambda: evaluate(s, u, v), 5)))
    n2 = N // 4
    rows.append(
        (
            "principal curvatures (order 2)",
            n2,
            *best_of(lambda: principal_curvatures(s, u[:n2], v[:n2]), 5),
        )
    )
    part = Part(surfaces=[degree5_patch(seed) for seed in range(50)])
    for i, surf in enumerate(part.surfaces):
        surf.id = i
    ids = rng.integers(0, 50, N)
    rows.append(
        ("evaluate_mixed over 50 surfaces", N, *best_of(lambda: evaluate_mixed(part, ids, u, v), 5))
    )
    g_rate = geomdl_rate(s, u[:500], v[:500])
    rows.append(("geomdl 5.4 per point (derivatives + cross)", 500, *[500 / g_rate] * 3))
    print(f"numba threads: {numba.get_num_threads()}")
    head = f"{'case':<42} {'points':>9} {'best s':>7} {'median s':>8} {'points/s':>11}"
    print(f"{head} {'per CPU s':>11}")
    for name, n, b, m, c in rows:
        print(f"{name:<42} {n:>9,} {b:>7.3f} {m:>8.3f} {n / b:>11,.0f} {n / c:>11,.0f}")
    step = REALDATA / "occt-cad-nurbs" / "ec_turbine-A.stp"
    if step.is_file():
        from checker.geometry import _CACHE, load_part
        from checker.geometry.sampling import sample_part

        def load():
            _CACHE.clear()
            return load_part(step)

        load()
        best, med, _ = best_of(load, repeat=3)
        part = load_part(step)
        t = time.perf_counter()
        tp = sample_part(part)
        ts = time.perf_counter() - t
        print(
            f"STEP ec_turbine-A.stp (53 faces): load best {best:.3f} s, median {med:.3f} s; "
            f"sampling {len(tp.points):,} test points {ts:.3f} s"
        )
    else:
        print(f"../shared/realdata not found at {REALDATA}: STEP timing skipped")


if __name__ == "__main__":
    main()
