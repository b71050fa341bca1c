"""Where every service request is recorded: a `Recorder` protocol, a no-op `NullRecorder`,
`StoreRecorder`, the adapter to the results store (`checker.store.ResultsStore`), and
`BackgroundRecorder`, the broker's (a thread of its own, which also applies the retention). A
recorder never fails a request: store errors are logged and swallowed."""

from __future__ import annotations

import logging
import queue
import threading
import time
from pathlib import Path
from typing import Any, Protocol

log = logging.getLogger("pathcheck.service")


class Recorder(Protocol):
    def record(
        self, op: str, reply: dict, elapsed_s: float, document: Any = None, job_path: str = ""
    ) -> None:
        """Record one answered request: its op (`?` when it did not parse), the reply object,
        the seconds the worker spent on it, and for `check` the ResultsDocument and job path."""


class NullRecorder:
    """Records nothing."""

    def record(
        self, op: str, reply: dict, elapsed_s: float, document: Any = None, job_path: str = ""
    ) -> None:
        return None


class StoreRecorder:
    """Records into a results store: a `requests` row per request, and for a checked job the
    full document as a `jobs` row (source `service`) that the request row points to."""

    def __init__(self, store: Any) -> None:
        self.store = store

    def record(
        self, op: str, reply: dict, elapsed_s: float, document: Any = None, job_path: str = ""
    ) -> None:
        try:
            job = None
            if document is not None:
                job = self.store.record_job(
                    document, elapsed_s=elapsed_s, job_path=job_path or None, source="service"
                )
            error = reply.get("error") or {}
            self.store.record_request(
                op, bool(reply.get("ok")), elapsed_s, error=error.get("message"), job=job
            )
        except Exception as err:  # the store must never take a request down with it
            log.warning("results store: request not recorded: %s", err)


def open_recorder(store_path: str | Path | None) -> Recorder:
    """A StoreRecorder on `store_path` (None: no recording); a store that cannot be opened is
    logged and requests go unrecorded."""
    if store_path is None:
        return NullRecorder()
    from checker.store import ResultsStore

    try:
        return StoreRecorder(ResultsStore(store_path))
    except Exception as err:
        log.warning("results store %s unavailable, requests are not recorded: %s", store_path, err)
        return NullRecorder()


class BackgroundRecorder:
    """Records on a thread of its own, so the broker's loop never waits for the store (the
    store is opened on that thread). With `keep_days` the same thread applies the store's
    retention (`ResultsStore.prune(keep_days=...)`, as `pathcheck store prune`) at start and
    every `prune_every_s`. `close()` records what is queued, then stops."""

    def __init__(self, store_path: str | Path | None, keep_days: float | None = None,
                 prune_every_s: float = 3600.0) -> None:
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self.keep_days = keep_days
        self.prune_every_s = prune_every_s
        self._thread = threading.Thread(target=self._run, args=(store_path,), daemon=True,
                                        name="pathcheck-recorder")
        self._thread.start()

    def record(
        self, op: str, reply: dict, elapsed_s: float, document: Any = None, job_path: str = ""
    ) -> None:
        self._queue.put((op, reply, elapsed_s, document, job_path))

    def close(self, timeout_s: float = 10.0) -> None:
        self._queue.put(None)
        self._thread.join(timeout_s)

    def _run(self, store_path: str | Path | None) -> None:
        recorder = open_recorder(store_path)
        store = getattr(recorder, "store", None)
        next_prune = time.monotonic()
        while True:
            if store is not None and self.keep_days is not None \
                    and time.monotonic() >= next_prune:
                self._prune(store)
                next_prune = time.monotonic() + self.prune_every_s
            try:
                item = self._queue.get(timeout=max(0.0, next_prune - time.monotonic()))
            except queue.Empty:
                continue
            if item is None:
                return
            recorder.record(*item)

    def _prune(self, store: Any) -> None:
        try:
            pruned = store.prune(keep_days=self.keep_days)
        except Exception as err:  # retention must never take the service down
            log.warning("results store: not pruned: %s", err)
            return
        log.info("results store pruned: %s", pruned)
