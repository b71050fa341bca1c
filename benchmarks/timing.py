"""Timing a benchmark's call: the best of a few runs (the machine is shared and noisy)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import NamedTuple


class Timing(NamedTuple):
    """`wall` the best run's wall time, `median` the median wall time, `cpu` the best run's CPU
    time (all threads of the process), seconds."""

    wall: float
    median: float
    cpu: float


def best_of(fn: Callable[[], object], repeat: int = 3, *, warm: bool = False) -> Timing:
    """Run `fn` `repeat` times (after one untimed run when `warm`, e.g. to compile kernels)."""
    if warm:
        fn()
    runs = []
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        fn()
        runs.append((time.perf_counter() - w, time.process_time() - c))
    best = min(runs)
    return Timing(best[0], statistics.median(w for w, _ in runs), best[1])
