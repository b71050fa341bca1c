"""Exact tool-vs-mesh depth speed. Run: `python -m benchmarks.bench_mesh`.

Poses per second of `checker.mesh.pose_depths` (warm cache: one warm-up call, best of 3 runs;
numba on 1 thread, i.e. per core, and on all threads) and of OpenCAMLib's drop-cutter (one
`BatchDropCutter` run over the same poses, 1 thread: a single drop, not the oracle's bisection)
on the real meshes RotateThin.STL and Interface-glue.STL of ../shared/realdata. Pose sets:
- `path opK`: the part's own APT tool path, operation K (its cutter; feed moves, 4 poses per
  move), vertical axis: tool tips on or near the finished surface;
- `near`: random poses near the surface (a random point of it, moved along its normal by
  -1.5..1.5 mm and up the axis by 0..4 mm), flat D10, ball D6, bull-nose D10 r2, vertical and
  tilted (20 degrees) axes.
`reach` 1 mm (clearances computed up to 1 mm). Columns: poses, share that cut (depth > 0), mean
candidate triangles from the tree, mean exact evaluations, poses/s on 1 thread and on all, OCL
poses/s ("-" where OCL has no such cutter: cone bottoms)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numba
import numpy as np

from benchmarks.timing import best_of
from checker.apt import read_cl
from checker.cutter import parse_cutter
from checker.geometry.stl_io import read_stl
from checker.mesh import MeshIndex, tool_pieces
from checker.mesh.depth import depths_of_tools
from checker.mesh.inputs import one_tool
from checker.mesh.pose import Poses

REALDATA = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "amorim-solidworkscam-apt"
MESHES = ("RotateThin", "Interface-glue")
REACH = 1.0
NEAR = 20_000


def near_poses(mesh, axis: np.ndarray, n: int, rng) -> np.ndarray:
    v = mesh.vertices[mesh.triangles]
    area = np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    t = rng.choice(len(v), n, p=area / area.sum())
    u = rng.random((n, 2))
    flip = u.sum(axis=1) > 1
    u[flip] = 1 - u[flip]
    p = v[t, 0] + u[:, :1] * (v[t, 1] - v[t, 0]) + u[:, 1:] * (v[t, 2] - v[t, 0])
    return p + mesh.normals[t] * rng.uniform(-1.5, 1.5, (n, 1)) + axis * rng.uniform(0, 4, (n, 1))


def path_poses(name: str):
    tp = read_cl(REALDATA / f"{name}.apt")
    m = tp.motion_arrays(arc_chord_tol=0.01)
    for k, op in enumerate(tp.operations):
        sel = (m.op == k) & ~m.rapid
        if sel.sum() < 50:
            continue
        tips = m.tip[sel]
        tips = np.concatenate([tips[:-1] + (tips[1:] - tips[:-1]) * f for f in (0, .25, .5, .75)])
        yield f"path op{k}", op.cutter, tips, np.array([0.0, 0.0, 1.0])


def ocl_rate(mesh, cutter, tips: np.ndarray, axis: np.ndarray):
    """Poses/s of one BatchDropCutter run (1 thread) over the poses; None without opencamlib or
    for a cutter it has no model of."""
    tests = str(Path(__file__).resolve().parents[1] / "tests")
    if tests not in sys.path:
        sys.path.insert(0, tests)
    try:
        from ocl_oracle import _surface, drop_heights, eroded_cutter, rotation_to_z
    except ImportError:
        return None
    if cutter.kind not in ("flat", "ball", "bullnose"):
        return None
    Q = rotation_to_z(axis)
    rt = mesh.vertices[mesh.triangles] @ Q.T
    surf, _ = _surface(rt)
    xy = (tips @ Q.T)[:, :2]
    z0 = float(rt[..., 2].min()) - 100.0
    dt = best_of(lambda: drop_heights(surf, eroded_cutter(cutter, 0.0), xy, z0, threads=1), 1,
                 warm=True).wall
    return len(tips) / dt


def run_case(index, cutter, tips, axis):
    pc = tool_pieces(cutter, with_holder=True)
    axes = np.ascontiguousarray(np.broadcast_to(axis, tips.shape))
    tips = np.ascontiguousarray(tips)

    tools = one_tool(pc)
    poses = Poses(tips, axes, np.zeros(len(tips), np.int64))

    def call():
        return depths_of_tools(index, tools, poses, -REACH, REACH)

    threads = numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(1)
    t1 = best_of(call, warm=True).wall
    numba.set_num_threads(threads)
    tn = best_of(call, warm=True).wall
    got, effort = call()
    return len(tips) / t1, len(tips) / tn, got.depth, effort


def main() -> None:
    if not REALDATA.is_dir():
        print(f"bench_mesh: {REALDATA} not found; nothing to measure")
        return
    rng = np.random.default_rng(0)
    tilted = np.array([np.sin(np.radians(20)), 0.0, np.cos(np.radians(20))])
    print(f"numba threads: {numba.config.NUMBA_NUM_THREADS}; reach {REACH} mm")
    head = (f"{'mesh':15s} {'poses':22s} {'cutter':9s} {'axis':5s} {'n':>6s} {'cut':>5s} "
            f"{'cand':>5s} {'exact':>6s} {'1 thread/s':>11s} {'all/s':>10s} {'OCL drop/s':>11s}")
    print(head)
    print("-" * len(head))
    for name in MESHES:
        path = REALDATA / f"{name}.STL"
        mesh = read_stl(path, path.read_bytes())
        MeshIndex.build(mesh.vertices[:3], np.array([[0, 1, 2]]))   # load the compiled builder
        t0 = time.perf_counter()
        index = MeshIndex.build(mesh.vertices, mesh.triangles)
        build = time.perf_counter() - t0
        print(f"{name}: {len(mesh.triangles)} triangles, tree built in {build * 1e3:.1f} ms, "
              f"{index.nbytes / 1e6:.2f} MB")
        cases = list(path_poses(name))
        for text in ("CUTTER/10", "CUTTER/6,3", "CUTTER/10,2"):
            c = parse_cutter(text)
            for axis in (np.array([0.0, 0.0, 1.0]), tilted):
                cases.append(("near", c, near_poses(mesh, axis, NEAR, rng), axis))
        for label, cutter, tips, axis in cases:
            one, many, d, effort = run_case(index, cutter, tips, axis)
            o = ocl_rate(mesh, cutter, tips, axis)
            kind = {"flat": "flat", "ball": "ball", "bullnose": "bull", "apt": "apt"}.get(
                cutter.kind, cutter.kind)
            print(f"{name:15s} {label:22s} {kind + ' D' + format(cutter.d, 'g'):9s} "
                  f"{'z' if axis[0] == 0 else '20deg':5s} {len(tips):6d} {np.mean(d > 0):5.2f} "
                  f"{effort.candidates.mean():5.1f} {effort.exact.mean():6.2f} {one:11,.0f} "
                  f"{many:10,.0f} {'-' if o is None else format(o, '11,.0f'):>11s}")


if __name__ == "__main__":
    main()
