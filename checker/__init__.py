"""pathcheck engine: CL reading, part geometry, cutter models, allowable-cutter search, 4-axis
orientation, verdicts, results store and report. Units: mm and radians inside unless stated.

Importing the package points numba's cache of compiled kernels at a per-user folder
(`kernel_cache.cache_dir`), so that kernels are compiled once per install, not once per checkout."""

from checker.kernel_cache import use_kernel_cache

__version__ = "0.1.0"

use_kernel_cache()
