"""What a test needs beyond the base install: an optional extra's module (OCP for `[cad]`,
`distributed` for `[dask]`, opencamlib for `[test]`). Locally a missing extra skips the test;
under CI (`CI` set, where `make test` installs `.[all]`) it fails, so a broken install cannot
pass as skips. Our own modules and base dependencies are imported plainly: an import error
fails the test."""

from __future__ import annotations

import importlib
import os
from types import ModuleType

import pytest


def missing(reason: str) -> None:
    """Skip with `reason`, or fail with it when `CI` is set (non-empty and not "0"/"false")."""
    if os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no"):
        pytest.fail(f"{reason} (CI installs .[all]: a missing extra is a failure there)",
                    pytrace=False)
    pytest.skip(reason, allow_module_level=True)


def require_extra(module: str, extra: str) -> ModuleType:
    """The module `module` of the optional extra `extra` (e.g. "OCP", "cad"), imported; when it
    cannot be imported, `missing(...)` naming both."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        missing(f"{module} is not installed (the [{extra}] extra): {exc}")
        raise  # unreachable: missing() raises
