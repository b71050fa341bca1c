"""Compile the kernels once per install, into the per-user cache (`checker.cache`). Two
processes compile the two big independent families at once (on 2 cores, about half the time):
the exact tool-vs-triangle depth (`checker.mesh`: a tool over a few triangles, its allowable
size there) and the allowable-cutter engine (`checker.engine`: a few CC points of the warm-up
part); then the bundled warm-up job (the demo job: the 4-axis compressor sample with a ball
D12, 90 CC points, flagged) is checked and posted as `pathcheck JOB -o JOB.nc` does, loading
those and compiling what is left. Afterwards that job compiles nothing; a job that needs more
(a flat end-mill's contour search, a large job's threaded variants) compiles those few on its
first run."""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from checker.cache import kernel_cache_dir
from checker.resources import resource

WARMUP_JOB = resource("warmup", "warmup.apt")
_FAMILIES = ("mesh", "engine")


def compile_mesh() -> None:
    """The mesh kernels: the tree, the depth of a tool's pieces, the allowable size."""
    import numpy as np

    from checker.cutter import parse_cutter
    from checker.mesh import MeshIndex, tool_pieces
    from checker.mesh.depth import allowable_on_mesh, pose_depths

    v = np.array([[-20.0, -20, 0], [20, -20, 0], [0, 20, 0], [0, 0, 10]])
    index = MeshIndex.build(v, np.array([[0, 1, 2], [0, 1, 3]]))
    cutter = parse_cutter("CUTTER/6,3")
    tips = np.array([[0.0, 0, 1], [0, -5, -0.1]])
    axes = np.tile([0.0, 0, 1], (2, 1))
    pose_depths(index, tool_pieces(cutter, with_holder=True), tips, axes, reach=1.0)
    allowable_on_mesh(index, cutter, np.zeros((1, 3)), axes[:1], axes[:1], tol=1e-6, s_max=10.0)


def compile_engine() -> None:
    """The engine's kernels: the allowable size at a few CC points of the warm-up part."""
    import numpy as np

    from checker.cutter import parse_cutter
    from checker.engine import allowable
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate
    from checker.geometry.sampling import sample_part

    part = load_part(WARMUP_JOB.with_suffix(".json"))
    ev = evaluate(part.surfaces[3], np.array([0.3, 0.5, 0.7]), np.array([0.5, 0.5, 0.5]))
    allowable(sample_part(part), part, parse_cutter("CUTTER/12,6"), ev.points, ev.normals,
              ev.normals, cc_surface=np.full(3, 3), cc_uv=np.array([[0.3, .5], [.5, .5], [.7, .5]]))


def warm_kernels() -> tuple[Path, float]:
    """(the kernel cache folder, seconds taken)."""
    t0 = time.perf_counter()
    procs = [subprocess.Popen([sys.executable, "-c", f"from checker.warm import compile_{name}; "
                               f"compile_{name}()"]) for name in _FAMILIES]
    for proc in procs:
        proc.wait()
    from checker.job import check_job

    with tempfile.TemporaryDirectory(prefix="pathcheck-warm-") as tmp:
        check_job(WARMUP_JOB, output=Path(tmp) / "warmup.nc")
    return kernel_cache_dir(), time.perf_counter() - t0
