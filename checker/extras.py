"""Optional dependencies (`pip install 'pathcheck[EXTRA]'`): importing one that is missing is
one line saying which extra to install, never a traceback."""

from __future__ import annotations

import importlib
from types import ModuleType

from checker.errors import PathcheckError


def require(module: str, extra: str, what: str) -> ModuleType:
    """Import `module`, which the optional dependencies `extra` provide for `what`."""
    try:
        return importlib.import_module(module)
    except ImportError as err:
        raise PathcheckError(
            f"{what} needs the optional '{extra}' dependencies ({err.name or module} is not "
            f"installed): pip install 'pathcheck[{extra}]'", code="extra") from err
