"""Compile the kernels once per install, into the per-user cache (`checker.cache`): the
bundled warm-up job (the demo job: the 4-axis compressor sample with a ball D12, 90 CC points,
flagged) is checked and posted as `pathcheck JOB -o JOB.nc` does. Afterwards that job loads
every kernel from the cache; a job that needs more (a flat end-mill's contour search, a
large job's threaded variants) compiles those few on its first run."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from checker.cache import kernel_cache_dir
from checker.resources import resource

WARMUP_JOB = resource("warmup", "warmup.apt")


def warm_kernels() -> tuple[Path, float]:
    """(the kernel cache folder, seconds taken)."""
    from checker.job import check_job

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="pathcheck-warm-") as tmp:
        check_job(WARMUP_JOB, output=Path(tmp) / "warmup.nc")
    return kernel_cache_dir(), time.perf_counter() - t0
