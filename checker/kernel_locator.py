"""Where numba keeps each compiled kernel of pathcheck's own files: under numba's cache folder
(`kernel_cache.use_kernel_cache` sets it), at the file's path inside the installation (e.g.
`checker/engine/refine/`), not at a hash of the absolute folder it was installed in as numba's own
locators do. So a wheel installed elsewhere, another checkout or another venv with the same sources
(the same `kernel_cache.source_key` folder) loads the kernels compiled once; numba still checks each
file's content (its source stamp is a hash of the text). numba imports this module by name
(`NUMBA_CACHE_LOCATOR_CLASSES`) when it first caches a kernel, so commands that compile nothing do
not import numba for it."""

from __future__ import annotations

import os
from pathlib import Path

from numba.core import config
from numba.core.caching import _CacheLocator, _SourceFileBackedLocatorMixin

_ROOT = Path(__file__).resolve().parents[1]  # the folder holding the packages
_PACKAGES = ("checker",)  # the packages that hold kernels


class PackageLocator(_SourceFileBackedLocatorMixin, _CacheLocator):
    """The cache folder of a kernel in one of pathcheck's packages: numba's cache folder joined
    with the kernel's file's folder relative to the installation."""

    def __init__(self, py_func, py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        inside = Path(py_file).resolve().parent.relative_to(_ROOT)
        self._cache_path = os.path.join(config.CACHE_DIR, *inside.parts)

    def get_cache_path(self) -> str:
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file: str):
        """A locator for kernels of pathcheck's packages when numba's cache folder is set (None
        for any other function: the next locator takes it)."""
        path = Path(py_file).resolve()
        if not config.CACHE_DIR or not path.is_relative_to(_ROOT) \
                or path.relative_to(_ROOT).parts[0] not in _PACKAGES:
            return None
        return super().from_function(py_func, py_file)
