"""The machine check in a batch folder: its `pathcheck-stock.toml` asks it (`machine`, a file
beside the jobs or a shipped name; `machine_clearance`, mm, or `machine_check = true`), and the
descent job of tests/collide_machines.py run by `run_batch` carries the nose on the block at the
closed form's Z in its stored document; a folder whose machine cannot be checked fails its jobs
with one line naming its file, and the batch goes on."""

from __future__ import annotations

from pathlib import Path

import pytest
from collide_machines import descent_job, machine_file, the_descent_finding
from requires import require_extra

from checker.batch import run_batch
from checker.store import ResultsStore

require_extra("coal", "machine")


def _folder(root: Path, name: str, toml: str) -> Path:
    job, _ = descent_job(root / name)
    machine_file(job.parent, "linuxcnc-head-head-ac", "").rename(job.parent / "bare.toml")
    (job.parent / "pathcheck-stock.toml").write_text(toml)
    return job


def test_a_folders_machine_check_is_run_and_stored(tmp_path):
    job = _folder(tmp_path, "cell", 'machine = "head.toml"\nmachine_clearance = 0.5\n')
    with ResultsStore(tmp_path / "s.sqlite") as store:
        (outcome,) = run_batch([job], store=store, workers=1)
        (row,) = store.jobs()
    assert outcome.error is None, outcome.error
    doc = outcome.results().model_dump(mode="json")
    assert doc["machine"]["clearance"] == 0.5
    the_descent_finding(doc["machine"])
    assert doc["summary"]["counts"]["machine"] == 1 and row.status == "findings"


@pytest.mark.parametrize("toml, said", [
    ('machine = "bare.toml"\nmachine_check = true\n',
     "machine_check: machine 'linuxcnc-head-head-ac' has no components"),
    ('machine = "head.toml"\nmachine_clearance = -1\n', "machine_clearance"),
    ('machine = "nowhere.toml"\nmachine_check = true\n', "nowhere.toml"),
])
def test_a_folder_whose_machine_cannot_be_checked_fails_its_jobs(tmp_path, toml, said):
    bad = _folder(tmp_path, "bad", toml)
    good = _folder(tmp_path, "good", 'machine = "head.toml"\nmachine_check = true\n')
    with ResultsStore(tmp_path / "s.sqlite") as store:
        first, last = run_batch([bad, good], store=store, workers=1)
    toml_path = str(bad.parent / "pathcheck-stock.toml")
    assert first.document is None and "\n" not in first.error
    assert first.error.startswith(toml_path) and said in first.error, first.error
    assert last.error is None and len(last.results().machine.findings) == 1
