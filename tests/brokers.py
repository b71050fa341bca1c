"""The service's broker as the service tests run it: started in a thread of the test process
with the service options a test module needs, its workers real processes; a client of one; and
a wait for the worker that runs a request."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from checker.client import Client
from checker.config import Config, default_config
from checker.service.broker import Broker
from checker.service.roots import Roots


def service_config(**service: object) -> Config:
    """The default config with these `[service]` options replaced."""
    base = default_config()
    return base.model_copy(update={"service": base.service.model_copy(update=service)})


@contextmanager
def running_broker(config: Config, *, workers: int = 2, roots: list[Path] | None = None,
                   bind: str = "tcp://127.0.0.1:*",
                   curve_keys: Path | None = None) -> Iterator[Broker]:
    """A broker on `bind` with `workers` worker processes, every one ready when this yields;
    stopped on exit, and then its thread must have ended and its workers be gone."""
    b = Broker(config, bind=bind, workers=workers, curve_keys=curve_keys,
               roots=Roots(roots) if roots is not None else None)
    thread = threading.Thread(target=b.run, daemon=True)
    thread.start()
    try:
        b.wait_started(60, ready_workers=workers)
        yield b
    finally:
        b.stop()
        thread.join(20)
    assert not thread.is_alive(), "broker did not stop"
    assert b.worker_pids() == [], "workers left running after the broker stopped"


@contextmanager
def client_of_root(root: Path) -> Iterator[Client]:
    """A client (no retries, 120 s timeout) of a one-worker broker with the default
    configuration that reads files under `root`."""
    with running_broker(default_config(), workers=1, roots=[root]) as broker, \
            Client(broker.address, timeout_s=120, retries=0) as c:
        yield c


def wait_busy(b: Broker, timeout_s: float = 20.0) -> int:
    """The process id of a worker running a request's op, once one is (else fail)."""
    deadline = time.monotonic() + timeout_s
    while not b.busy_pids():
        assert time.monotonic() < deadline, "no worker became busy"
        time.sleep(0.01)
    return b.busy_pids()[0]
