"""Shared fixtures. Tests that read ../shared skip with a message when it is absent."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
REALDATA = SHARED / "realdata"


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def realdata() -> Path:
    """../shared/realdata, or skip the test when the folder is absent."""
    if not REALDATA.is_dir():
        pytest.skip(f"../shared/realdata not found at {REALDATA}; real-data tests skipped")
    return REALDATA
