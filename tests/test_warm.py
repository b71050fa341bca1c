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


def test_warm_compiles_for_this_cpu_and_marks_the_folder(tmp_path, monkeypatch):
    """`pathcheck warm` compiles for this CPU ("host") into the kernel cache folder, then marks
    it (cache.HOST_MARK) so that later processes take these kernels instead of the portable
    ones; the portable build compiles for the generic CPU and stamps what it serves."""
    from checker import warm
    from checker.cache import HOST_MARK, PORTABLE_STAMP, portable_stamp

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


def test_the_engines_kernels_compile_one_signature_each():
    """A Python int constant passed to a kernel (numba types it as its literal value), a
    parallel loop's index (uint64 there) or a read-only array compiles the kernel once more:
    after the engine ran on CC points of the warm-up part as `pathcheck warm` runs it (with
    their own axes, serial, and on 4,000 rows with one axis, threaded), each of these kernels
    holds one signature (eval_range held 8, the descent 4)."""
    from checker import warm
    from checker.engine.refine import rings, steps
    from checker.engine.scan import bound, sweep
    from checker.geometry import evaluate

    warm.compile_engine()
    kernels = {"eval_range": evaluate.eval_range, "steps._exact": steps._exact,
               "steps._refine_rows": steps._refine_rows, "bound._descend": bound._descend,
               "bound._warm_row": bound._warm_row, "bound._coarse_row": bound._coarse_row,
               "sweep._block": sweep._block, "rings._sizes_at": rings._sizes_at,
               "rings._on_ring": rings._on_ring}
    signatures = {name: len(k.signatures) for name, k in kernels.items()}
    assert signatures == dict.fromkeys(kernels, 1)
