"""Batch runs with a folder's `pathcheck-stock.toml`: its jobs are checked against the stock and
the fixtures it states (files relative to the folder), the store keeps each job's stock line and
the report page shows it in its "stock and fixtures" column; a bad file fails its folder's jobs
with one line naming it, and the batch goes on."""

from __future__ import annotations

import html
import re
import shutil
from pathlib import Path

import pytest
from hostile import SMALL_JOB
from vise import MOULD, vise

from checker.batch import run_batch
from checker.report import build_report
from checker.results import stock_line
from checker.store import ResultsStore

GOOD = 'stock = "box:+2"\nfixtures = ["vise.stl"]\nresolution = 0.5\n'


def _folder(root: Path, name: str, toml: str | None) -> list[Path]:
    """A folder of two jobs (the mould job and its first 40 records), their parts beside them
    and the vise, with `toml` as its pathcheck-stock.toml."""
    folder = root / name
    folder.mkdir()
    for stem in ("mould", "small"):
        shutil.copy(MOULD / "mould.json", folder / f"{stem}.json")
    shutil.copy(MOULD / "mould.apt", folder / "mould.apt")
    (folder / "small.apt").write_text(SMALL_JOB)
    vise(folder / "vise.stl")
    if toml is not None:
        (folder / "pathcheck-stock.toml").write_text(toml)
    return [folder / "mould.apt", folder / "small.apt"]


def test_a_folders_stock_is_checked_stored_and_reported(tmp_path):
    jobs = _folder(tmp_path, "cell", GOOD)
    with ResultsStore(tmp_path / "s.sqlite") as store:
        outcomes = run_batch(jobs, store=store, workers=1)
        rows = {Path(r.job_path).name: r for r in store.jobs()}
        for outcome in outcomes:
            assert outcome.error is None, outcome.error
            doc = outcome.results()
            s = doc.stock
            assert s.resolution == 0.5 and s.fixtures == ["vise.stl"]
            assert s.counts.crash == 0 and s.counts.holder == 0
            assert s.stock.startswith("box from (-82, -57, -24.9981) to (82, 57, 2)")
            assert 0.0 < s.volume_final < s.volume_initial
            row = rows[Path(outcome.path).name]
            assert row.status == "ok" and row.stock == stock_line(s)
            assert row.stock.startswith("stock box from (-82, -57, -24.9981) to (82, 57, 2)")
            assert "fixtures vise.stl: crash 0  holder 0; removed" in row.stock
        # the short job removes less: it stops after 40 records of the same path
        small, mould = (rows[n].stock for n in ("small.apt", "mould.apt"))
        assert _removed(small) < _removed(mould)
        files = build_report(store, tmp_path / "report.html")
    page = html.unescape(files.html.read_text())
    assert "stock and fixtures" in page
    cells = re.findall(r'<td class="stock">(.*?)</td>', page, flags=re.S)
    assert sorted(cells) == sorted([small, mould])


def _removed(line: str) -> float:
    return float(re.search(r"removed (\d+) of", line).group(1))


@pytest.mark.parametrize("toml, said", [
    ('stock = "box:+x"\n', "--stock 'box:+x': expected box:+M"),
    ('stock = "box:+2"\nfixtures = ["jaws.stl"]\n', "jaws.stl: fixture file not found"),
    ('stock = "box:+2"\nfixtures = ["vise.stl@1,2"]\n', "vise.stl@1,2': expected 'rx,ry,rz"),
    ('stock = "box:+2"\nresolution = 0\n', "resolution"),
    ('stock = "box:+2"\nclamps = ["vise.stl"]\n', "clamps"),
    ('stock = "box:+2\n', ""),
])
def test_a_bad_stock_file_fails_its_folders_jobs_and_the_batch_goes_on(tmp_path, toml, said):
    bad = _folder(tmp_path, "bad", toml)
    good = _folder(tmp_path, "good", None)[1:]  # the short job, no stock file
    with ResultsStore(tmp_path / "s.sqlite") as store:
        outcomes = run_batch([*bad, *good], store=store, workers=1)
        rows = {r.job_path: r for r in store.jobs()}
    toml_path = str(tmp_path / "bad" / "pathcheck-stock.toml")
    for outcome in outcomes[:2]:
        assert outcome.document is None and "\n" not in outcome.error
        assert outcome.error.startswith(f"{toml_path}"), outcome.error
        assert said in outcome.error
        assert rows[outcome.path].status == "failed"
        assert rows[outcome.path].error == outcome.error
    (last,) = outcomes[2:]
    assert last.error is None and rows[last.path].status == "ok"
    assert rows[last.path].stock is None
