"""Batch runs: job discovery, a local process pool and a Dask LocalCluster giving the same
results documents, failures recorded with their reason while the batch goes on, and the
`pathcheck batch` command."""

from __future__ import annotations

from pathlib import Path

import numba
import pytest
from requires import require_extra
from synthetic_results import synthetic_document

from checker.batch import find_jobs, run_batch, run_one
from checker.cli import main
from checker.errors import PathcheckError
from checker.store import ResultsStore

SYNTHETIC = "synthetic_results:synthetic_job"
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture()
def jobs(tmp_path) -> tuple[Path, list[Path]]:
    """Four synthetic jobs (SEED N files, see synthetic_job) and one bad one, in sub-folders."""
    folder = tmp_path / "night"
    paths = []
    for k in range(4):
        p = folder / f"cell{k % 2}" / f"job{k}.apt"
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(f"{k} 11\n")
        paths.append(p)
    bad = folder / "cell0" / "broken.apt"
    bad.write_text("GOTO/1,2\n")
    (folder / "notes.txt").write_text("not a CL file")
    return folder, sorted([*paths, bad])


def test_find_jobs(jobs):
    folder, paths = jobs
    assert find_jobs(folder) == paths
    assert find_jobs(str(folder / "**" / "job*.apt")) == [p for p in paths if "job" in p.name]
    assert find_jobs(paths[0]) == [paths[0]]
    with pytest.raises(PathcheckError, match="found nothing"):
        find_jobs(folder / "*.nc")


def test_failures_are_recorded_and_the_batch_goes_on(jobs, tmp_path):
    folder, paths = jobs
    seen = []
    with ResultsStore(tmp_path / "s.sqlite") as store:
        outcomes = run_batch(paths, store=store, workers=2, job_function=SYNTHETIC,
                             on_result=seen.append)
        rows = {r.job_path: r for r in store.jobs()}
    assert [o.path for o in outcomes] == [str(p) for p in paths] and len(seen) == 5
    broken = outcomes[0]
    assert broken.document is None
    assert broken.error.startswith(f"{paths[0]}:1: expected 'SEED N'")
    assert rows[str(paths[0])].status == "failed" and rows[str(paths[0])].error == broken.error
    for p, o in zip(paths[1:], outcomes[1:], strict=True):
        k = int(p.stem[-1])
        assert o.results() == synthetic_document(k, n=11, four_axis=k % 2 == 0, path=str(p))
        assert rows[str(p)].status == "findings" and rows[str(p)].source == "batch"


def test_an_internal_fault_is_a_failed_job_not_a_crash(jobs):
    _, paths = jobs
    outcome = run_one(str(paths[1]), job_function="json:loads")  # raises JSONDecodeError
    assert outcome.document is None
    assert "internal error JSONDecodeError" in outcome.error and str(paths[1]) in outcome.error


def _dask_vs_local(paths: list[Path], job_function: str, tmp_path: Path) -> None:
    distributed = require_extra("distributed", "dask")
    local = run_batch(paths, store=None, workers=2, job_function=job_function)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, \
            ResultsStore(tmp_path / "dask.sqlite") as store:
        remote = run_batch(paths, store=store, scheduler=cluster.scheduler_address,
                           job_function=job_function)
        recorded = {r.job_path: store.document(r.id) for r in store.jobs()}
    for a, b in zip(local, remote, strict=True):
        assert (a.path, a.error) == (b.path, b.error)
        if a.document is not None:
            da, db = a.results(), b.results()
            da.summary.time_s = db.summary.time_s = 0.0  # wall time is the one thing that differs
            assert da == db
            assert recorded[a.path].points == da.points


def test_dask_cluster_gives_the_local_documents(jobs, tmp_path):
    _, paths = jobs
    _dask_vs_local(paths, SYNTHETIC, tmp_path)


def test_dask_cluster_on_the_sample_jobs(tmp_path):
    samples = sorted((REPO / "samples").rglob("*_small.apt"))
    assert samples, "the bundled samples/*/*_small.apt are missing"
    _dask_vs_local(samples, "checker.check:check_job", tmp_path)


def test_unreachable_scheduler_is_a_clear_error(jobs):
    _, paths = jobs
    with pytest.raises(PathcheckError, match="Dask scheduler"):
        run_batch(paths[:1], store=None, scheduler="tcp://127.0.0.1:9", job_function=SYNTHETIC,
                  connect_timeout_s=1.0)


def test_batch_command(jobs, tmp_path, monkeypatch, capsys):
    folder, paths = jobs
    monkeypatch.setenv("PATHCHECK_STORE", str(tmp_path / "cli.sqlite"))
    with pytest.raises(SystemExit) as exit_info:
        main(["batch", str(folder), "--workers", "2", "--job-function", SYNTHETIC])
    assert exit_info.value.code == 1  # findings and a failure
    captured = capsys.readouterr()
    assert "5 jobs: 0 clean, 4 with findings, 1 failed" in captured.out
    assert "expected 'SEED N'" in captured.err
    with ResultsStore() as store:
        assert sorted(r.status for r in store.jobs()) == ["failed"] + ["findings"] * 4
    with pytest.raises(SystemExit) as exit_info:
        main(["batch", str(folder / "nothing-*.apt")])
    assert exit_info.value.code == 2


def crash_on_seed_2(apt_path: str):
    """A job function whose process dies on the job with seed 2 (a segfault in an engine)."""
    import os

    from synthetic_results import synthetic_job

    if Path(apt_path).read_text().split()[0] == "2":
        os._exit(3)
    return synthetic_job(apt_path)


def test_a_dying_worker_process_fails_its_job_alone(jobs, tmp_path):
    _, paths = jobs
    good = [p for p in paths if p.stem.startswith("job")]
    with ResultsStore(tmp_path / "s.sqlite") as store:
        outcomes = run_batch(good, store=store, workers=2,
                             job_function=f"{__name__}:crash_on_seed_2")
        recorded = {r.job_path: r.status for r in store.jobs()}
    by_path = {o.path: o for o in outcomes}
    seed_2 = str(next(p for p in good if p.stem == "job2"))
    died = by_path[seed_2]
    assert died.document is None and "worker process running it died twice" in died.error
    assert len(outcomes) == len(recorded) == 4  # every job has an outcome, recorded
    assert recorded[seed_2] == "failed"
    others = [o for o in outcomes if o.path != seed_2]  # retried after the pool broke: own results
    assert all(o.error is None and recorded[o.path] == "findings" for o in others)


def test_find_jobs_knows_cl_files_by_content(realdata, tmp_path):
    """NX CLSF listings saved as .txt are jobs; notes, licences, parts and G-code are not."""
    clsf = sorted((realdata / "mech491-nx-clsf").glob("APT_*.txt"))
    assert len(clsf) == 7
    assert find_jobs(realdata / "mech491-nx-clsf") == clsf  # LICENSE, SOURCES.txt skipped
    amorim = realdata / "amorim-solidworkscam-apt"
    assert find_jobs(amorim) == sorted(amorim.glob("*.apt"))  # README quotes CUTTER/: skipped
    folder = tmp_path / "mixed"
    folder.mkdir()
    for source, name in ((clsf[2], "facing.cls"), (clsf[3], "variable.ptp"),
                         (REPO / "samples" / "mould" / "mould.apt", "mould.clsf"),
                         (REPO / "samples" / "mould" / "mould.json", "mould.json"),
                         (realdata / "linuxcnc-5axis-gcode" / "b-index.ngc", "b-index.txt"),
                         (realdata / "bladex-propeller-iges" / "lower.stl", "lower.txt"),
                         (amorim / "SOURCES.txt", "notes.txt")):
        (folder / name).write_bytes(source.read_bytes())
    assert [p.name for p in find_jobs(folder)] == ["facing.cls", "mould.clsf", "variable.ptp"]
    assert [p.name for p in find_jobs(str(folder / "*"))] == ["facing.cls", "mould.clsf",
                                                              "variable.ptp"]


def motions_job(apt_path: str):
    """A job function that reads the CL file (any dialect) and reports its motion count as
    `summary.cl_points` of a small synthetic document."""
    from checker.apt import read_cl

    doc = synthetic_document(0, n=2, four_axis=False, path=apt_path)
    doc.summary.cl_points = len(read_cl(apt_path, require_cutter=False).motion_arrays().tip)
    return doc


def test_batch_runs_the_nx_listings_through_the_reader(realdata, tmp_path):
    folder = tmp_path / "nx"
    folder.mkdir()
    for source in (realdata / "mech491-nx-clsf").iterdir():
        (folder / source.name).write_bytes(source.read_bytes())
    jobs = find_jobs(folder)
    outcomes = run_batch(jobs, store=None, workers=1, job_function=f"{__name__}:motions_job")
    assert [o.error for o in outcomes] == [None] * 7
    for job, outcome in zip(jobs, outcomes, strict=True):
        gotos = sum(line.lstrip().upper().startswith("GOTO/")
                    for line in job.read_text(errors="replace").splitlines())
        assert outcome.results().summary.cl_points == gotos > 0, job.name


def threads_job(apt_path: str):
    """Records the numba threads and the Dask worker of the task beside the job, then runs it."""
    import numba
    from distributed import get_worker
    from synthetic_results import synthetic_job

    Path(apt_path + ".ran").write_text(f"{numba.get_num_threads()} {get_worker().address}")
    return synthetic_job(apt_path)


def test_dask_from_the_environment_one_numba_thread_per_task_and_a_retry(jobs, tmp_path,
                                                                          monkeypatch, capsys):
    """`pathcheck batch` on the cluster of DASK_SCHEDULER_ADDRESS, each task on one numba
    thread (this thread's count untouched); a task that fails on its worker runs again."""
    distributed = require_extra("distributed", "dask")
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one numba thread on this machine: nothing to cap")
    _, paths = jobs
    good = [p for p in paths if p.stem.startswith("job")]
    monkeypatch.setenv("PATHCHECK_STORE", str(tmp_path / "cli.sqlite"))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", cluster.scheduler_address)
        with pytest.raises(SystemExit) as exit_info:
            main(["batch", str(good[0].parent.parent / "**" / "job*.apt"),
                  "--job-function", f"{__name__}:threads_job"])
        (worker,) = cluster.scheduler_info["workers"]
        calls = []
        cap = numba.set_num_threads

        def flaky(n: int) -> None:  # the first task fails on its worker, outside run_one
            calls.append(n)
            if len(calls) == 1:
                raise RuntimeError("numba's thread pool is not available")
            cap(n)

        monkeypatch.setattr(numba, "set_num_threads", flaky)  # the worker is in this process
        retried = run_batch(good[:2], store=None, scheduler=cluster.scheduler_address,
                            job_function=SYNTHETIC)
    assert exit_info.value.code == 1  # the synthetic jobs have findings
    assert "4 jobs: 0 clean, 4 with findings, 0 failed" in capsys.readouterr().out
    ran = [Path(f"{p}.ran").read_text().split() for p in good]
    assert ran == [["1", worker]] * 4  # on the cluster's worker, one numba thread each
    assert numba.get_num_threads() == numba.config.NUMBA_NUM_THREADS  # this thread: untouched
    assert [o.error for o in retried] == [None, None] and calls == [1, 1, 1]  # one retry
