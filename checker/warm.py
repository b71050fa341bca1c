"""Compile the kernels once per install, into the per-user cache (`checker.kernel_cache`). Two
processes compile at once: the refinement's step kernel (first, so that the other process
finds it cached when it gets there, which shortens the whole), the exact tool-vs-triangle depth
(`checker.mesh`: a tool over a few triangles, its allowable size there) and the orientation
along a 4-axis path; and the allowable-cutter engine (`checker.engine`: CC points of the
warm-up part; the best-B scan's coarse engine runs the same kernels). Then the bundled warm-up
job (the demo job: the 4-axis compressor sample with a ball D12, 90 CC points, flagged) is
checked and posted as `pathcheck JOB -o JOB.nc` does, loading those and compiling what is
left. The engine also runs on many CC points with one axis, for the kernels' threaded variants,
which a large job takes (without them a large job's first run after `warm` compiles them).
Afterwards neither job compiles
anything; a job that needs more (a flat end-mill's contour search) compiles those few on its
first run.

`pathcheck warm` compiles for this CPU and marks the cache folder so (`kernel_cache.HOST_MARK`:
later processes take these kernels instead of the portable ones a wheel ships); `make wheel` builds
the portable ones the same way for `kernel_cache.PORTABLE_CPU` (`build_portable`, run as `python -m
checker.warm --portable FOLDER` on a CPU that runs that code)."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from checker.kernel_cache import (
    HOST_MARK,
    KERNELS_ENV,
    PORTABLE_CPU,
    PORTABLE_STAMP,
    kernel_cache_dir,
    portable_stamp,
    runs_portable,
)
from checker.resources import resource

WARMUP_JOB = resource("warmup", "warmup.apt")
_FAMILIES = ("step_mesh_and_plan", "engine")
_WARM_ROWS = 4000  # CC points: enough for the threaded kernels (see _allowable_at_the_warm_up_part)


def compile_step_mesh_and_plan() -> None:
    """The refinement's step kernel, the mesh kernels (the tree, the depth of a tool's pieces, a
    stretch certified whole, the allowable size) and the 4-axis plan's own (the shortest path
    over B)."""
    import numpy as np

    _refinement_step()
    from checker.cutter import parse_cutter
    from checker.mesh import MeshIndex, tool_pieces
    from checker.mesh.allowable import allowable_on_mesh
    from checker.mesh.depth import pose_depths
    from checker.mesh.swept import certified_stretches

    v = np.array([[-20.0, -20, 0], [20, -20, 0], [0, 20, 0], [0, 0, 10]])
    index = MeshIndex.build(v, np.array([[0, 1, 2], [0, 1, 3]]))
    cutter = parse_cutter("CUTTER/6,3")
    tips = np.array([[0.0, 0, 1], [0, -5, -0.1]])
    axes = np.tile([0.0, 0, 1], (2, 1))
    pieces = tool_pieces(cutter, with_holder=True)
    pose_depths(index, pieces, tips, axes, reach=1.0)
    certified_stretches(index, pieces, tips, axes, tips, np.zeros(2), np.zeros(2), np.ones(2))
    allowable_on_mesh(index, cutter, np.zeros((1, 3)), axes[:1], axes[:1], tol=1e-6, s_max=10.0)
    _plan()


def _plan() -> None:
    import numpy as np

    from checker.config import default_config
    from checker.four_axis.orientation import shortest_path_orientation

    fa = default_config().four_axis
    n = 4
    shortest_path_orientation(
        [[(-10.0, 10.0)]] * n, np.zeros(n), np.zeros(n), np.ones(n), b_min=-30.0, b_max=30.0,
        grid_step=fa.dp_b_step, w_change=fa.dp_weight_change,
        w_original=fa.dp_weight_original, max_db_per_mm=fa.max_db_per_mm)


def _refinement_step() -> None:
    """`steps.compile_step` for a CC point of the warm-up part (its frames as `allowable` makes
    them)."""
    import numpy as np

    from checker.config import default_config
    from checker.cutter import parse_cutter
    from checker.engine.api import tool_frames
    from checker.engine.refine.steps import compile_step
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate
    from checker.geometry.sampling import sample_part

    part = load_part(WARMUP_JOB.with_suffix(".json"))
    cutter = parse_cutter("CUTTER/12,6")
    ev = evaluate(part.surfaces[3], np.array([0.5]), np.array([0.5]))
    frames = tool_frames(sample_part(part), cutter, ev.points, ev.normals, ev.normals, None,
                         default_config())
    compile_step(part, cutter, frames.frame, frames.Q)


def compile_engine() -> None:
    """The engine's kernels: the allowable size at CC points of the warm-up part."""
    _allowable_at_the_warm_up_part()


def _allowable_at_the_warm_up_part() -> None:
    """The allowable size of a ball D12 on the warm-up part's blade: at three points with their
    own tool axes (the kernels' serial variants), and at _WARM_ROWS points with one axis
    (enough rows in one bin of axes for their threaded variants, which a large job's batches
    take), hinted at size 0: a first trial too small for most rows, which then take the
    scan's bounds as a large job's rows do."""
    import numpy as np

    from checker.cutter import parse_cutter
    from checker.engine import allowable
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate
    from checker.geometry.sampling import sample_part

    part = load_part(WARMUP_JOB.with_suffix(".json"))
    tp, cutter = sample_part(part), parse_cutter("CUTTER/12,6")
    grid = (a.ravel() for a in np.meshgrid(np.linspace(0.2, 0.8, _WARM_ROWS // 20),
                                            np.linspace(0.2, 0.8, 20)))
    for u, v, one_axis in ((np.array([0.3, 0.5, 0.7]), np.full(3, 0.5), False), (*grid, True)):
        ev = evaluate(part.surfaces[3], u, v)
        axes = ev.normals.mean(axis=0) if one_axis else ev.normals  # one axis: broadcast
        allowable(tp, part, cutter, ev.points, ev.normals, axes, cc_surface=np.full(u.size, 3),
                  cc_uv=np.column_stack([u, v]), hint=np.zeros(u.size) if one_axis else None)


def _check_warm_up_job() -> None:
    """The warm-up job checked and posted as the demo runs it (`make demo`)."""
    from checker.check import check_job
    from checker.check.options import CheckOptions

    with tempfile.TemporaryDirectory(prefix="pathcheck-warm-") as tmp:
        check_job(WARMUP_JOB, options=CheckOptions(output=Path(tmp) / "warmup.nc",
                                                   on_findings="stop"))


def _compile_all(folder: Path, kernels: str) -> None:
    """Compile the families (two processes at once), then the warm-up job (a third), into the
    numba cache `folder`, for this CPU (`kernels` "host") or `kernel_cache.PORTABLE_CPU`
    ("portable")."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(folder), **{KERNELS_ENV: kernels})

    def run(call: str) -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-c", f"from checker.warm import {call}; "
                                 f"{call}()"], env=env)

    procs = [run(f"compile_{name}") for name in _FAMILIES]
    failed = [proc.wait() for proc in procs] + [run("_check_warm_up_job").wait()]
    if any(failed):
        raise RuntimeError(f"compiling the kernels failed (exit {max(failed)})")


def warm_kernels() -> tuple[Path, float]:
    """Compile this CPU's kernels into the cache folder and mark it so: (the folder, seconds
    taken)."""
    t0 = time.perf_counter()
    folder = kernel_cache_dir()
    _compile_all(folder, "host")
    (folder / HOST_MARK).touch()
    return folder, time.perf_counter() - t0


def build_portable(out: Path) -> float:
    """The portable kernels (`kernel_cache.PORTABLE_CPU`) of these sources in the new folder `out`,
    stamped with what they serve (`kernel_cache.portable_stamp`): seconds taken. The warm-up runs
    them, so this CPU must run them."""
    if not runs_portable():
        raise SystemExit(f"building the portable kernels needs a CPU that runs {PORTABLE_CPU} "
                         "code (AVX2, FMA)")
    t0 = time.perf_counter()
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    _compile_all(out, "portable")
    (out / PORTABLE_STAMP).write_text(portable_stamp() + "\n")
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description="Build the portable kernels a wheel ships.")
    ap.add_argument("--portable", type=Path, required=True, metavar="FOLDER",
                    help="the new folder (checker/resources/kernels for `make wheel`)")
    seconds = build_portable(ap.parse_args().portable)
    print(f"portable kernels built in {seconds:.1f} s")


if __name__ == "__main__":
    main()
