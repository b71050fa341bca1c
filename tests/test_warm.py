"""The kernel cache: `pathcheck warm` compiles into the folder PATHCHECK_CACHE_DIR names (never
into the source tree), and afterwards the demo job, checked and posted in a new process,
compiles nothing; the warm-up job is the demo job."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

from checker.cache import source_key
from checker.resources import resource

_NO_COMPILE = textwrap.dedent("""
    import sys
    from numba.core import event
    compiled = []

    class Compiles(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data["dispatcher"].py_func.__qualname__)

        def on_end(self, ev):
            pass

    event.register("numba:compile", Compiles())
    from checker.job import check_job
    check_job(sys.argv[1], output=sys.argv[2], on_findings="stop")
    print("compiled:", " ".join(compiled))
""")


def test_warm_fills_the_user_cache_and_the_demo_then_compiles_nothing(repo, tmp_path):
    cache = tmp_path / "cache"
    env = dict(os.environ, PATHCHECK_CACHE_DIR=str(cache))
    env.pop("NUMBA_CACHE_DIR", None)
    warm = subprocess.run([sys.executable, "-m", "checker.cli", "warm"], capture_output=True,
                          text=True, env=env, timeout=900)
    assert warm.returncode == 0, warm.stderr
    assert f"kernels compiled into {cache / 'numba' / source_key()} in " in warm.stdout
    assert any(cache.rglob("*.nbi")) and any(cache.rglob("*.nbc"))
    assert not any((repo / "checker").rglob("*.nbi")), "kernels cached in the source tree"
    demo = repo / "samples/compressor/compressor_small_d12.apt"
    run = subprocess.run([sys.executable, "-c", _NO_COMPILE, str(demo), str(tmp_path / "d.nc")],
                         capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "compiled:", run.stdout
    assert (tmp_path / "d.nc").stat().st_size > 0


def test_the_warm_up_job_is_the_demo_job(repo):
    for suffix in (".apt", ".json"):
        shipped = resource("warmup", "warmup" + suffix).read_bytes()
        sample = repo / "samples/compressor" / f"compressor_small_d12{suffix}"
        assert shipped == sample.read_bytes()
