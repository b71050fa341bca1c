"""Batch runs: job discovery, a local process pool and a Dask LocalCluster giving the same
results documents, failures recorded with their reason while the batch goes on, and the
`pathcheck batch` command."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from checker.batch import find_jobs, run_batch, run_one
from checker.cli import main
from checker.errors import PathcheckError
from checker.report.synthetic import synthetic_document
from checker.store import ResultsStore

SYNTHETIC = "checker.report.synthetic:synthetic_job"
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
    distributed = pytest.importorskip("distributed")
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
    if importlib.util.find_spec("checker.job") is None:
        pytest.skip("checker.job.check_job (the engine issue) is not there yet")
    samples = sorted((REPO / "samples").rglob("*_small.apt")) or sorted(
        (REPO / "samples").rglob("*.apt"))
    if not samples:
        pytest.skip("no sample jobs in samples/ yet")
    _dask_vs_local(samples, "checker.job:check_job", tmp_path)


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

    from checker.report.synthetic import synthetic_job

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
