"""The stock simulation's material removal (checker/stock, docs/MATH.md §14): moves/s and
engaged rays/s on (1) a 100,000-move 3-axis ball-nose finishing raster over a 100 x 100 x 50 mm
box at h = 0.1 mm and (2) the amorim Interface-glue job on a box 3 mm around its STL at
h = 0.05 mm. Peak memory: run under `/usr/bin/time -v`.

    python -m benchmarks.bench_stock [raster|bullnose|poses|amorim|all]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from checker.cutter import Cutter
from checker.mesh.tool import tool_pieces
from checker.stock.dexels import Dexels
from checker.stock.removal import remove

AMORIM = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "amorim-solidworkscam-apt"
Z = np.array([0.0, 0.0, 1.0])


def _warm() -> float:
    """Compile (or load) the kernels on a tiny job; seconds."""
    t = time.perf_counter()
    stock = Dexels.box([0, 0, 0], [5, 5, 5], 0.5)
    ball = Cutter("ball", d=2.0, r=1.0, R=0.0, flute_length=5.0)
    remove(stock, tool_pieces(ball, with_holder=False), [[0, 0, 4.0]], [[5, 5, 4.5]],
           [Z], [0], 1, step=0.1)
    return time.perf_counter() - t


def _report(name: str, n_moves: int, seconds: float, stock: Dexels, engaged_rays: int,
            removed: float) -> None:
    print(f"{name}: {n_moves} moves in {seconds:.2f} s = {n_moves / seconds:,.0f} moves/s; "
          f"{engaged_rays:,} engaged rays (summed over moves) = "
          f"{engaged_rays / seconds:,.0f} rays/s; "
          f"removed {removed:,.0f} mm^3; grid {stock.nx} x {stock.ny} at h = {stock.h} mm; "
          f"overflow {stock.overflow}")


def raster(n_moves: int = 100_000, kind: str = "ball") -> None:
    """A ball-nose R = 3 mm (or a bull-nose D 6 mm r 1 mm: the searched profile) finishing
    raster of 1 mm moves over z = 45 + 2 sin(x/10) cos(y/10) on a 100 x 100 x 50 mm box at
    h = 0.1 mm."""
    per_line = 100
    lines = n_moves // per_line
    stock = Dexels.box([0, 0, 0], [100, 100, 50], 0.1)
    ys = np.linspace(0.0, 100.0, lines)
    xs = np.linspace(0.0, 100.0, per_line + 1)
    a, b = [], []
    for k, y in enumerate(ys):
        x = xs if k % 2 == 0 else xs[::-1]
        z = 45.0 + 2.0 * np.sin(x / 10.0) * np.cos(y / 10.0)
        p = np.stack([x, np.full_like(x, y), z], axis=1)
        a.append(p[:-1])
        b.append(p[1:])
    a, b = np.concatenate(a), np.concatenate(b)
    axis = np.tile(Z, (len(a), 1))
    if kind == "ball":
        cutter = Cutter("ball", d=6.0, r=3.0, R=0.0, flute_length=20.0)
    else:
        cutter = Cutter("bullnose", d=6.0, r=1.0, R=2.0, flute_length=20.0)
    pieces = tool_pieces(cutter, with_holder=False)
    t, c = time.perf_counter(), time.process_time()
    rem = remove(stock, pieces, a, b, axis, np.arange(len(a)), len(a), step=0.1)
    dt = time.perf_counter() - t
    print(f"  cpu {time.process_time() - c:.2f} s over all threads")
    _report(f"raster {kind}", len(a), dt, stock, int(rem.rays.sum()), float(rem.volume.sum()))


def poses(n: int = 20_000) -> None:
    """A 5-axis-like chain of n poses of a ball D 10 mm tilting +-30 degrees about y along a
    wave over a 100 x 100 x 50 mm box at h = 0.1 mm (the sampled path, 14.3)."""
    stock = Dexels.box([0, 0, 0], [100, 100, 50], 0.1)
    ball = Cutter("ball", d=10.0, r=5.0, R=0.0, flute_length=30.0)
    x = np.linspace(10.0, 90.0, n)
    tilt = np.radians(30.0) * np.sin(x / 7.0)
    axis = np.stack([np.sin(tilt), np.zeros(n), np.cos(tilt)], axis=1)
    tips = np.stack([x, 50.0 + 20.0 * np.sin(x / 10.0), np.full(n, 47.0)], axis=1)
    t, c = time.perf_counter(), time.process_time()
    rem = remove(stock, tool_pieces(ball, with_holder=False), tips, tips, axis,
                 np.arange(n), n, step=0.05)
    dt = time.perf_counter() - t
    print(f"  cpu {time.process_time() - c:.2f} s over all threads")
    _report("5-axis poses", n, dt, stock, int(rem.rays.sum()), float(rem.volume.sum()))


def _stl_bounds(path: Path) -> tuple[np.ndarray, np.ndarray]:
    from stl import mesh
    m = mesh.Mesh.from_file(str(path))
    pts = m.vectors.reshape(-1, 3)
    return pts.min(axis=0), pts.max(axis=0)


def amorim(h: float = 0.05) -> None:
    """The Interface-glue job, operation by operation with each one's cutter, on its STL's box
    grown by 3 mm."""
    from checker.apt import read_cl
    from checker.moves import START, machine_moves
    apt = AMORIM / "Interface-glue.apt"
    if not apt.is_file():
        print(f"amorim: {apt} not found; skipped")
        return
    tp = read_cl(apt)
    mv = machine_moves(tp.motion_arrays(arc_chord_tol=0.001))
    lo, hi = _stl_bounds(AMORIM / "Interface-glue.STL")
    stock = Dexels.box(lo - 3.0, hi + 3.0, h)
    ends = np.flatnonzero(mv.kind != START)
    ops = tp.motion_arrays(arc_chord_tol=0.001).op[mv.row[ends]]
    total, n_items, removed, engaged = 0.0, 0, 0.0, 0
    for o in np.unique(ops):
        sel = ends[ops == o]
        cutter = tp.operations[int(o)].cutter
        pieces = tool_pieces(cutter, with_holder=True)
        a, b, axis = mv.tip[sel - 1], mv.tip[sel], mv.axis[sel]
        t, c = time.perf_counter(), time.process_time()
        rem = remove(stock, pieces, a, b, axis, np.arange(len(sel)), len(sel), step=0.05)
        dt = time.perf_counter() - t
        cpu = time.process_time() - c
        total += dt
        n_items += len(sel)
        removed += float(rem.volume.sum())
        engaged += int(rem.rays.sum())
        print(f"  op {o} {tp.operations[int(o)].name}: {len(sel)} moves, cutter {cutter.kind} "
              f"d={cutter.d:g}, removed {rem.volume.sum():,.0f} mm^3, "
              f"air moves {int(np.sum(rem.volume.sum(axis=1) <= 0.0))}, "
              f"engaged rays {int(rem.rays.sum()):,}, {dt:.2f} s (cpu {cpu:.2f} s)")
    _report("amorim Interface-glue", n_items, total, stock, engaged, removed)


def main(argv: list[str]) -> None:
    which = argv[0] if argv else "all"
    print(f"compile/load: {_warm():.1f} s")
    if which in ("raster", "all"):
        raster()
    if which in ("bullnose", "all"):
        raster(kind="bullnose")
    if which in ("poses", "all"):
        poses()
    if which in ("amorim", "all"):
        amorim()


if __name__ == "__main__":
    main(sys.argv[1:])
