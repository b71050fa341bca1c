"""The results store: round trip, migrations, concurrent writers, and files that are locked,
corrupt, newer or foreign (a clear error, never overwritten)."""

from __future__ import annotations

import hashlib
import sqlite3
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from synthetic_results import synthetic_document

from checker.cli import main
from checker.errors import PathcheckError
from checker.report import build_report
from checker.store import MIGRATIONS, SCHEMA_VERSION, ResultsStore, point_arrays


@pytest.fixture(scope="module")
def doc():
    return synthetic_document(3, n=41)


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_round_trip_of_a_41x41_job(tmp_path, doc):
    with ResultsStore(tmp_path / "s.sqlite") as store:
        job_id = store.record_job(doc, elapsed_s=2.5, source="cli")
        (row,) = store.jobs()
        assert row.id == job_id and row.source == "cli" and row.elapsed_s == 2.5
        assert row.status == "findings"  # the synthetic mould gouges
        c = doc.summary.counts
        assert (row.n_ok, row.n_gouge, row.n_interference) == (c.ok, c.gouge, c.interference)
        assert row.n_within_tolerance == c.within_tolerance
        assert (row.n_ok + row.n_gouge + row.n_interference + row.n_within_tolerance
                == 41 * 41 == row.points)
        assert row.worst_depth == doc.summary.worst_depth
        assert row.worst_margin == doc.summary.worst_margin
        assert (row.part_hash, row.cutter, row.cutter_kind) == (
            doc.job.part_hash, doc.job.cutter, "ball")
        assert store.document(job_id) == doc
        arrays = store.arrays(job_id)
        np.testing.assert_array_equal(arrays["cc"], np.array([p.cc for p in doc.points]))
        gouges = np.array([p.verdict == "gouge" for p in doc.points])
        assert int(np.sum(arrays["verdict"] == 1)) == gouges.sum() == c.gouge
        assert store.schema_version == SCHEMA_VERSION


def test_failed_job_and_requests_are_recorded(tmp_path, doc):
    with ResultsStore(tmp_path / "s.sqlite") as store:
        bad = store.record_job(None, error="job.apt:7: expected GOTO/x,y,z", job_path="job.apt",
                               elapsed_s=0.01, source="batch")
        good = store.record_job(doc, elapsed_s=1.0)
        store.record_request("check", True, 0.5, job=good)
        store.record_request("check", False, 0.1, error="bad cutter")
        rows = {r.id: r for r in store.jobs()}
        assert rows[bad].status == "failed" and rows[bad].error.startswith("job.apt:7:")
        assert store.document(bad) is None and store.arrays(bad) is None
        reqs = store.requests()
        assert [(r[1], r[2], r[4], r[5]) for r in reqs] == [
            ("check", 1, None, good), ("check", 0, "bad cutter", None)]


def test_time_window_and_previous(tmp_path, doc):
    with ResultsStore(tmp_path / "s.sqlite") as store:
        for t in (100.0, 200.0, 300.0):
            store.record_job(doc, elapsed_s=1.0, recorded_at=t, job_path="a.apt")
        assert [r.recorded_at for r in store.jobs(since=150.0, until=300.0)] == [200.0]
        assert store.previous("a.apt", 300.0).recorded_at == 200.0
        assert store.previous("a.apt", 100.0) is None


def test_path_from_environment(tmp_path, monkeypatch):
    target = tmp_path / "deep" / "env.sqlite"
    monkeypatch.setenv("PATHCHECK_STORE", str(target))
    with ResultsStore() as store:
        assert store.path == target
    assert target.is_file()


def _writer(args: tuple[str, int]) -> int:
    path, k = args
    small = synthetic_document(k, n=5)
    with ResultsStore(path, busy_timeout_s=30.0) as store:
        for i in range(15):
            store.record_job(small, elapsed_s=0.0, job_path=f"w{k}/{i}.apt", source="batch")
            store.record_request("check", True, 0.0)
    return k


def test_concurrent_writers_lose_nothing(tmp_path):
    path = str(tmp_path / "s.sqlite")
    with ProcessPoolExecutor(3) as pool:
        assert sorted(pool.map(_writer, [(path, k) for k in range(4)])) == [0, 1, 2, 3]
    with ResultsStore(path) as store:
        rows = store.jobs()
        assert len(rows) == 60 and len({r.job_path for r in rows}) == 60
        assert len(store.requests()) == 60
    assert sqlite3.connect(path).execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_locked_store_is_a_clear_error(tmp_path, doc):
    path = tmp_path / "s.sqlite"
    ResultsStore(path).close()
    holder = sqlite3.connect(path, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")
    try:
        with ResultsStore(path, busy_timeout_s=0.2) as store, pytest.raises(PathcheckError) as err:
            store.record_job(doc, elapsed_s=1.0)
        assert "locked" in str(err.value) and str(path) in str(err.value)
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    with ResultsStore(path) as store:
        assert store.jobs() == []


@pytest.mark.parametrize("kind", ["corrupt", "newer", "foreign"])
def test_bad_store_file_is_never_overwritten(tmp_path, kind):
    path = tmp_path / "s.sqlite"
    if kind == "corrupt":
        path.write_bytes(b"this is not an SQLite file at all\n" * 200)
    else:
        con = sqlite3.connect(path)
        if kind == "newer":
            con.execute("CREATE TABLE jobs (id INTEGER)")
            con.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 5}")
        else:
            con.execute("CREATE TABLE invoices (id INTEGER)")
        con.commit()
        con.close()
    before = _digest(path)
    with pytest.raises(PathcheckError) as err:
        ResultsStore(path)
    text = str(err.value)
    assert str(path) in text
    expected = {"corrupt": "unreadable", "newer": "newer", "foreign": "other tables"}[kind]
    assert expected in text
    assert _digest(path) == before


def test_cli_reports_a_corrupt_store_in_one_line(tmp_path, monkeypatch, capsys):
    path = tmp_path / "s.sqlite"
    path.write_bytes(b"garbage" * 100)
    monkeypatch.setenv("PATHCHECK_STORE", str(path))
    with pytest.raises(SystemExit) as exit_info:
        main(["report", "--out", str(tmp_path / "r.html")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(path) in err and "Traceback" not in err
    assert not (tmp_path / "r.html").exists()


def test_migration_from_version_1_keeps_rows(tmp_path, doc):
    """A store of version 1 is migrated through 2 (per-point arrays) and 3 (the
    within-tolerance and crash counts) and keeps its rows."""
    path = tmp_path / "old.sqlite"
    con = sqlite3.connect(path)
    con.executescript(MIGRATIONS[0])
    con.execute(
        "INSERT INTO jobs (recorded_at, source, status, job_path, elapsed_s, n_gouge) "
        "VALUES (5.0, 'cli', 'findings', 'old.apt', 1.0, 7)"
    )
    con.execute("PRAGMA user_version = 1")
    con.commit()
    con.close()
    with ResultsStore(path) as store:
        assert store.schema_version == SCHEMA_VERSION == 5
        (old,) = store.jobs()
        assert (old.job_path, old.n_gouge, old.cutter_kind, old.n_crash, old.n_machine) == (
            "old.apt", 7, None, None, None)
        assert store.arrays(old.id) is None
        store.record_job(doc, elapsed_s=1.0)
        assert len(store.jobs()) == 2
        files = build_report(store, tmp_path / "r.html", since_s=1e10)
    assert files.jobs == 2 and files.pictures == 4 + 1  # the old row has a row, no pictures
    assert "old.apt" in files.html.read_text()


def test_point_arrays_nulls(doc):
    three_axis = synthetic_document(1, n=5, four_axis=False)
    arrays = point_arrays(three_axis)
    assert arrays["cc"].shape == (25, 3) and np.isnan(arrays["b_best"]).all()
    assert arrays["kind"].all() and set(np.unique(arrays["surface"])) <= {0, 1}


def test_one_store_shared_by_threads(tmp_path):
    from concurrent.futures import ThreadPoolExecutor

    small = synthetic_document(2, n=5)
    with ResultsStore(tmp_path / "s.sqlite") as store:
        def write(k: int) -> None:
            for i in range(10):
                store.record_job(small, elapsed_s=0.0, job_path=f"t{k}/{i}.apt")
                store.jobs(since=0.0)

        with ThreadPoolExecutor(4) as pool:
            list(pool.map(write, range(4)))
        assert len({r.job_path for r in store.jobs()}) == 40
