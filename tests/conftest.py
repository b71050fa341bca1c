"""Shared fixtures. Tests that read ../shared skip with a message when it is absent."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
REALDATA = SHARED / "realdata"


@pytest.fixture(scope="session", autouse=True)
def own_results_store(tmp_path_factory):
    """Checks that record without naming a store record in one of the test session's own
    (`PATHCHECK_STORE`), never in the user's: the suite neither reads nor writes a store it
    did not make (a tester's own, or one a newer pathcheck wrote)."""
    if "PATHCHECK_STORE" in os.environ:
        yield
        return
    os.environ["PATHCHECK_STORE"] = str(tmp_path_factory.mktemp("store") / "results.sqlite")
    yield
    os.environ.pop("PATHCHECK_STORE", None)


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def realdata() -> Path:
    """../shared/realdata, or skip the test when the folder is absent."""
    if not REALDATA.is_dir():
        pytest.skip(f"../shared/realdata not found at {REALDATA}; real-data tests skipped")
    return REALDATA
