"""The warm-up job `pathcheck warm` compiles with is the demo job. (That `warm` compiles into the
folder PATHCHECK_CACHE_DIR names, never beside the sources, and that the demo job and the
compressor job in a new process then compile nothing, `make test` checks on the installed wheel
from an empty cache: tools/wheel-check.sh.)"""

from __future__ import annotations

import os
import subprocess
import sys

from checker.resources import resource


def test_the_warm_up_job_is_the_demo_job(repo):
    for suffix in (".apt", ".json"):
        shipped = resource("warmup", "warmup" + suffix).read_bytes()
        sample = repo / "samples/compressor" / f"compressor_small_d12{suffix}"
        assert shipped == sample.read_bytes()


def test_warm_compiles_for_this_cpu_and_marks_the_folder(tmp_path, monkeypatch):
    """`pathcheck warm` compiles for this CPU ("host") into the kernel cache folder, then marks
    it (kernel_cache.HOST_MARK) so that later processes take these kernels instead of the portable
    ones; the portable build compiles for the generic CPU and stamps what it serves."""
    from checker import warm
    from checker.kernel_cache import HOST_MARK, PORTABLE_STAMP, portable_stamp

    calls = []
    monkeypatch.setattr(warm, "_compile_all", lambda folder, kernels: calls.append(
        (folder, kernels, (folder / HOST_MARK).exists())))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "user"))
    (tmp_path / "user").mkdir()
    folder, _, _ = warm.warm_kernels()
    assert calls == [(tmp_path / "user", "host", False)]
    assert (folder / HOST_MARK).is_file()
    out = tmp_path / "kernels"
    (out / "stale").mkdir(parents=True)
    warm.build_portable(out)
    assert calls[1] == (out, "portable", False)
    assert not (out / "stale").exists()
    assert (out / PORTABLE_STAMP).read_text().split() == portable_stamp().split()


_BOUNDS = """
import numpy as np

from checker.cutter import parse_cutter
from checker.engine.grid.candidates import SERIAL_ROWS
from checker.engine.scan import bound
from checker.engine.sizes import SizeArgs

rng = np.random.default_rng(1)
xyz = rng.uniform(-5.0, 5.0, (40, 3))
knn = np.array([[(i + 1) % 40, (i + 39) % 40] for i in range(40)], dtype=np.int64)
sizes = []
for n in (3, SERIAL_ROWS + 4):  # the serial kernel, then the threaded one
    rot = np.tile(np.eye(3), (n, 1, 1))
    cc = rng.uniform(-1.0, 1.0, (n, 3))
    cc[:, 2] = -8.0
    sz = SizeArgs(cc, np.tile([0.0, 0.0, 1.0], (n, 1)), np.zeros((n, 3)), np.zeros(n),
                  np.zeros(n), parse_cutter("CUTTER/6,3").kernel_params(), True, 50.0, 0.0)
    starts = rng.integers(0, 40, (n, 2))
    starts.flags.writeable = n < SERIAL_ROWS  # a read-only array too
    sizes.append(bound.warm_bounds(xyz, rot, starts, sz, knn).upper)
print(len(bound._warm_row.signatures), len(bound._descend.signatures),
      bool(np.isfinite(np.concatenate(sizes)).all()))
"""


def test_the_scans_kernels_compile_one_signature_each(tmp_path):
    """A Python int constant passed to a kernel (numba types it as its literal value), a
    parallel loop's index (uint64 in the loop's body) and a read-only array each compiled a
    kernel once more: compiled from an empty cache, the scan's bounds from start points, serial
    and threaded, leave one signature of the row's kernel and of its descent (there were 3 and
    4), and a finite bound on every row (test points above a ball's CC point, all reachable)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    done = subprocess.run([sys.executable, "-c", _BOUNDS], capture_output=True, text=True,
                          env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["1", "1", "True"]
