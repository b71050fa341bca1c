"""The warm-up job `pathcheck warm` compiles with is the demo job. (That `warm` compiles into the
folder PATHCHECK_CACHE_DIR names, never beside the sources, and that the demo job and the
compressor job in a new process then compile nothing, `make test` checks on the installed wheel
from an empty cache: tools/wheel-check.sh.)"""

from __future__ import annotations

from checker.resources import resource


def test_the_warm_up_job_is_the_demo_job(repo):
    for suffix in (".apt", ".json"):
        shipped = resource("warmup", "warmup" + suffix).read_bytes()
        sample = repo / "samples/compressor" / f"compressor_small_d12{suffix}"
        assert shipped == sample.read_bytes()
