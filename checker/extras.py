"""Optional dependencies (`pip install 'pathcheck[EXTRA]'`): one that is missing is one line
saying which extra to install, never a traceback."""

from __future__ import annotations

from importlib.util import find_spec

from checker.errors import PathcheckError


def require(module: str, extra: str, what: str) -> None:
    """Check that the top-level `module`, which the optional dependencies `extra` provide for
    `what`, is installed, without importing it (OpenCASCADE is slow to import, and the
    STEP/IGES reader imports it in its own process)."""
    if find_spec(module) is None:
        raise PathcheckError(
            f"{what} needs the optional '{extra}' dependencies ({module} is not "
            f"installed): pip install 'pathcheck[{extra}]'", code="extra")
