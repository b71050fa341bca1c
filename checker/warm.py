"""Compile the kernels once per install, into the per-user cache (`checker.kernel_cache`). Two
processes at once (two cores): one checks and posts the bundled warm-up job (the demo job: the
4-axis compressor sample with a ball D12, 90 CC points, flagged) as `pathcheck JOB -o JOB.nc`
does, compiling what it needs in the order it needs it (the mesh of the tool and holder, the
scan, the rings, the refinement, the 4-axis plan); the other compiles at the same time what the
job needs later, the certified stretches (`mesh.swept`), the refinement (`steps.refine`, the
largest kernels) and the plan, so that the job mostly finds them cached when it gets there.
Then the first process compiles what a large job takes beyond the demo's: the engine on many CC
points with one axis (the kernels' threaded variants; the compressor sample's first run after
`warm` compiled six kernels without them) and the rest of the mesh's kernels. Afterwards
neither job compiles anything; a job that needs more (a flat end-mill's contour search)
compiles those few on its first run.

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
from resource import RUSAGE_CHILDREN, getrusage

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
# two processes at once, each a sequence of this module's functions: the warm-up job, then what
# a large job needs beyond it; beside it, what the warm-up job needs later
_PROCESSES = (("check_warm_up_job", "compile_large_job"),
              ("compile_stretches", "compile_refinement", "compile_plan"))
_WARM_ROWS = 4000  # CC points: enough for the threaded kernels (see _allowable_at_the_warm_up_part)


def compile_large_job() -> None:
    """What a large job needs beyond the warm-up job: the engine's threaded variants
    (`compile_engine`) and the rest of the mesh's kernels (`compile_mesh`)."""
    compile_engine()
    compile_mesh()


def _small_mesh() -> tuple:
    """A four-triangle tree, a ball D6 tool's pieces with its holder, two poses (tips, axes)."""
    import numpy as np

    from checker.cutter import parse_cutter
    from checker.mesh import MeshIndex, tool_pieces

    v = np.array([[-20.0, -20, 0], [20, -20, 0], [0, 20, 0], [0, 0, 10]])
    index = MeshIndex.build(v, np.array([[0, 1, 2], [0, 1, 3]]))
    cutter = parse_cutter("CUTTER/6,3")
    tips = np.array([[0.0, 0, 1], [0, -5, -0.1]])
    axes = np.tile([0.0, 0, 1], (2, 1))
    return index, cutter, tool_pieces(cutter, with_holder=True), tips, axes


def compile_stretches() -> None:
    """A stretch of moves certified whole (`mesh.swept`), the mesh kernels the warm-up job needs
    after the tool's depths."""
    import numpy as np

    from checker.mesh.swept import certified_stretches

    index, _, pieces, tips, axes = _small_mesh()
    certified_stretches(index, pieces, tips, axes, tips, np.zeros(2), np.zeros(2), np.ones(2))


def compile_mesh() -> None:
    """The mesh kernels: the tree, the depth of a tool's pieces, a stretch certified whole, the
    allowable size."""
    import numpy as np

    from checker.mesh.allowable import allowable_on_mesh
    from checker.mesh.depth import pose_depths

    index, cutter, pieces, tips, axes = _small_mesh()
    pose_depths(index, pieces, tips, axes, reach=1.0)
    compile_stretches()
    allowable_on_mesh(index, cutter, np.zeros((1, 3)), axes[:1], axes[:1], tol=1e-6, s_max=10.0)


def compile_plan() -> None:
    """The 4-axis plan's own kernel (the shortest path over B)."""
    import numpy as np

    from checker.config import default_config
    from checker.four_axis.orientation import shortest_path_orientation

    fa = default_config().four_axis
    n = 4
    shortest_path_orientation(
        [[(-10.0, 10.0)]] * n, np.zeros(n), np.zeros(n), np.ones(n), b_min=-30.0, b_max=30.0,
        grid_step=fa.dp_b_step, w_change=fa.dp_weight_change,
        w_original=fa.dp_weight_original, max_db_per_mm=fa.max_db_per_mm)


def compile_refinement() -> None:
    """`steps.refine` (the kernels of the whole refinement) from one start at a CC point of the
    warm-up part, with the types `allowable` passes it (its frames as `allowable` makes
    them)."""
    import numpy as np

    from checker.config import default_config
    from checker.cutter import parse_cutter
    from checker.engine.api import tool_frames
    from checker.engine.refine.steps import refine
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate
    from checker.geometry.sampling import sample_part

    part = load_part(WARMUP_JOB.with_suffix(".json"))
    cutter = parse_cutter("CUTTER/12,6")
    ev = evaluate(part.surfaces[3], np.array([0.5]), np.array([0.5]))
    frames = tool_frames(sample_part(part), cutter, ev.points, ev.normals, ev.normals, None,
                         default_config())
    refine(part, cutter, frames.frame, frames.Q, np.zeros(1, dtype=np.int64),
           np.full(1, 3, dtype=np.int64), np.full((1, 2), 0.5), np.full((1, 2), 0.01))


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


def check_warm_up_job() -> None:
    """The warm-up job checked and posted as the demo runs it (`make demo`)."""
    from checker.check import check_job
    from checker.check.options import CheckOptions

    with tempfile.TemporaryDirectory(prefix="pathcheck-warm-") as tmp:
        check_job(WARMUP_JOB, options=CheckOptions(output=Path(tmp) / "warmup.nc",
                                                   on_findings="stop"))


def _compile_all(folder: Path, kernels: str) -> None:
    """The `_PROCESSES` (at once) into the numba cache `folder`, for this CPU (`kernels` "host")
    or `kernel_cache.PORTABLE_CPU` ("portable")."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(folder), **{KERNELS_ENV: kernels})

    def run(calls: tuple[str, ...]) -> subprocess.Popen:
        code = "import checker.warm as w; " + "; ".join(f"w.{call}()" for call in calls)
        return subprocess.Popen([sys.executable, "-c", code], env=env)

    failed = [proc.wait() for proc in [run(calls) for calls in _PROCESSES]]
    if any(failed):
        raise RuntimeError(f"compiling the kernels failed (exit {max(failed)})")


def _children_cpu() -> float:
    """CPU seconds (user + system) of this process's waited-for child processes so far."""
    used = getrusage(RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def warm_kernels() -> tuple[Path, float, float]:
    """Compile this CPU's kernels into the cache folder and mark it so: (the folder, seconds
    taken, CPU seconds of the compiling processes)."""
    t0, cpu0 = time.perf_counter(), _children_cpu()
    folder = kernel_cache_dir()
    _compile_all(folder, "host")
    (folder / HOST_MARK).touch()
    return folder, time.perf_counter() - t0, _children_cpu() - cpu0


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
