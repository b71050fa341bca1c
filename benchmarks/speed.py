"""pathcheck's speed in one run, with the field's reference beside it (`make bench` starts here).
Run: `python -m benchmarks.speed [--quick]`.

Prints, on this machine, in this run (so the ratios hold on a noisy machine):
- the allowable-cutter engine on the mould sample (every CC point of its job), CC points/s per
  cutter (the best of 3 calls); the thesis's PSO baseline on a subset; OpenCAMLib's
  drop-cutter (the field's reference speed, the easier problem of one drop height per point) on
  the same part as triangles (within 0.005 mm of its surfaces) at the same points, 2 threads;
- `pathcheck allowable` with 100 CC points end to end (a fresh process: start-up, part, answer);
- `pathcheck info` and `pathcheck --help` (start-up);
- the full 4-axis compressor job (best B over -180..180, the program written and checked) and
  the largest amorim mesh job (Interface-glue), each in a fresh process: wall time, peak memory;
  Interface-glue again against a box stock 3 mm around its part at 0.05 mm (`--stock box:+3`):
  the stock simulation's own time beside the check's, and the machined part's comparison with
  the design beside the simulation (`benchmarks.bench_deviation` alone);
- the stock's material removal alone (`benchmarks.bench_stock`): moves/s and engaged rays/s on a
  100,000-move 3-axis raster and on Interface-glue.
The kernels come from the warm per-user cache (`pathcheck warm`)."""

from __future__ import annotations

import argparse
import json
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.timing import best_of

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
MOULD = ROOT / "samples" / "mould" / "mould.apt"
COMPRESSOR = ROOT / "samples" / "compressor" / "compressor.apt"
AMORIM = ROOT.parent / "shared" / "realdata" / "amorim-solidworkscam-apt" / "Interface-glue.apt"
CUTTERS = ("CUTTER/10,5", "CUTTER/10,2", "CUTTER/10", "CUTTER/9.1633,5,0,5,0,5,0")
PATHCHECK = [sys.executable, "-m", "checker.cli"]


def _timed(cmd: list[str], ok=(0, 1)) -> tuple[float, float]:
    """(wall s, peak MB) of a command in a fresh process (peak: the largest child so far)."""
    t = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if done.returncode not in ok:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
    return wall, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0


def _mould_contacts():
    from checker.apt import read_cl
    from checker.geometry import load_part
    from checker.geometry.contact import cl_to_cc
    from checker.geometry.sampling import sample_part

    tp = read_cl(MOULD)
    ma = tp.motion_arrays()
    cut = ~ma.rapid
    part = load_part(MOULD.with_suffix(".json"))
    samples = sample_part(part)
    con = cl_to_cc(part, samples, tp.operations[0].cutter, ma.tip[cut], ma.axis[cut])
    return part, samples, con


def engine_rates(n_pso: int) -> None:
    from checker.config import default_config
    from checker.cutter import parse_cutter
    from checker.engine import allowable
    from checker.geometry.tessellate import part_triangles

    part, samples, con = _mould_contacts()
    cc, nrm, own = con.cc, con.normal, {"cc_surface": con.surface, "cc_uv": con.uv}
    tri = part_triangles(part, 0.005, default_config().geometry)
    n = len(cc)
    sub = np.linspace(0, n - 1, n_pso).astype(int)
    print(f"mould: {n} CC points, {len(samples.points)} test points, "
          f"{len(tri.triangles)} triangles for OpenCAMLib")
    print(f"{'cutter':28} {'engine CC/s':>12} {'PSO CC/s':>9} {'engine/PSO':>10} "
          f"{'OCL drop CC/s':>13} {'engine/OCL':>10}")
    for text in CUTTERS:
        c = parse_cutter(text)
        allowable(samples, part, c, cc[:8], nrm[:8], cc_surface=con.surface[:8],
                  cc_uv=con.uv[:8])  # the kernels loaded
        rate = n / best_of(lambda c=c: allowable(samples, part, c, cc, nrm, **own)).wall
        t = time.perf_counter()
        allowable(samples, part, c, cc[sub], nrm[sub], cc_surface=con.surface[sub],
                  cc_uv=con.uv[sub], method="pso", seed=1)
        pso = len(sub) / (time.perf_counter() - t)
        ocl = _ocl_rate(tri, c, cc)
        ocl_text = f"{ocl:13.0f} {rate / ocl:10.2f}" if ocl else f"{'-':>13} {'-':>10}"
        print(f"{text:28} {rate:12.0f} {pso:9.1f} {rate / pso:10.0f} {ocl_text}")


def _ocl_rate(tri, cutter, cc: np.ndarray) -> float | None:
    """OpenCAMLib's BatchDropCutter over the triangles at the CC points' (x, y), 2 threads:
    points/s (None for the cutters it does not have)."""
    try:
        from ocl_oracle import _surface, drop_heights, eroded_cutter
        oc = eroded_cutter(cutter, 0.0)
    except (ImportError, ValueError):
        return None
    surf, _ = _surface(tri.vertices[tri.triangles])
    z0 = float(tri.vertices[:, 2].min()) - 10.0
    t = time.perf_counter()
    drop_heights(surf, oc, cc[:, :2], z0, threads=2)
    return len(cc) / (time.perf_counter() - t)


def cli_times() -> None:
    part, _, con = _mould_contacts()
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "cc.csv"
        rows = np.column_stack([con.cc, con.normal])[np.linspace(0, len(con.cc) - 1,
                                                                 100).astype(int)]
        np.savetxt(csv, rows, delimiter=",", header="x,y,z,nx,ny,nz", comments="")
        wall, _ = _timed([*PATHCHECK, "allowable", "--part", str(MOULD.with_suffix(".json")),
                          "--cc", str(csv), "--cutter", "CUTTER/10,5"])
    print(f"pathcheck allowable, 100 CC points, end to end: {wall:.2f} s")
    for args in (["info", str(COMPRESSOR)], ["--help"]):
        wall, _ = _timed([*PATHCHECK, *args])
        print(f"pathcheck {' '.join(a if '/' not in a else Path(a).name for a in args)}: "
              f"{wall:.2f} s")


def jobs() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for job in (COMPRESSOR, AMORIM):
            if not job.is_file():
                print(f"{job.name}: not found")
                continue
            cmd = [*PATHCHECK, str(job), "--json", str(Path(tmp) / "out.json"), "-o",
                   str(Path(tmp) / "out.nc"), "--on-findings", "comment"]
            wall, peak = _timed(cmd)
            print(f"job {job.name}: {wall:.1f} s wall, peak {peak:.0f} MB (largest process "
                  "so far)")
        if AMORIM.is_file():
            out = Path(tmp) / "stock.json"
            wall, peak = _timed([*PATHCHECK, str(AMORIM), "--json", str(out), "--no-store",
                                 "--stock", "box:+3", "--stock-resolution", "0.05"])
            doc = json.loads(out.read_text())
            st = doc["stock"]
            print(f"job {AMORIM.name} with --stock box:+3 at 0.05 mm: {wall:.1f} s wall "
                  f"(the stock simulation {st['time_s']:.1f} s of the check's "
                  f"{doc['summary']['time_s']:.1f} s), peak {peak:.0f} MB; removed "
                  f"{st['volume_initial'] - st['volume_final']:,.0f} mm^3, air cuts "
                  f"{sum(o['air_cuts'] for o in st['operations'])}")
            m = st["machined"]                        # inside the stock's time_s above
            print(f"  the machined part against the design: {m['time_s']:.1f} s beside the "
                  f"simulation's {st['time_s'] - m['time_s']:.1f} s, {m['points']:,} points")


def stock_removal() -> None:
    from benchmarks import bench_stock

    bench_stock.main(["all"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="engine rates only")
    args = ap.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, "
          f"{len(__import__('os').sched_getaffinity(0))} cores, Python {platform.python_version()}")
    engine_rates(n_pso=20)
    if args.quick:
        return
    cli_times()
    jobs()
    stock_removal()


if __name__ == "__main__":
    main()
