"""Steps of long work and how far they are, told to whoever watches: the library calls
`step(name, total)` around a step and the `advance(n)` it yields between compiled batches
(never per point inside a hot loop); nothing is shown unless a caller installed a view with
`watching(view)` (the CLI: a rich bar on a terminal, `--verbose` step times; see
`checker.commands.terminal`). No rich here: the numeric code imports this module."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Protocol


class View(Protocol):
    """What a watcher is told: a step starts (its total in its own units, None if unknown),
    advances, ends after `seconds` of wall time."""

    def start(self, name: str, total: float | None) -> None: ...

    def advance(self, amount: float) -> None: ...

    def end(self, name: str, seconds: float) -> None: ...


_view: View | None = None


def _nothing(amount: float = 1.0) -> None:
    """`advance` when nobody watches."""


@contextmanager
def step(name: str, total: float | None = None) -> Iterator[Callable[[float], None]]:
    """A step of the work named for a person ("load part"); yields `advance(amount)`."""
    view = _view
    if view is None:
        yield _nothing
        return
    started = time.perf_counter()
    view.start(name, total)
    try:
        yield view.advance
    finally:
        view.end(name, time.perf_counter() - started)


@contextmanager
def watching(view: View) -> Iterator[View]:
    """Install `view` for the steps run inside (one view at a time; the previous comes back)."""
    global _view
    previous, _view = _view, view
    try:
        yield view
    finally:
        _view = previous
