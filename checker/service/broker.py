"""The service's broker: a ROUTER front end for clients (REQ or DEALER), a ROUTER back end for
worker processes, and the load-balancing loop between them (pyzmq's load-balancing broker
pattern: a request goes only to an idle worker, so one slow job never blocks the others). The
most recently idle worker is taken first, so a client calling again for the same part finds it
in that worker's part cache.

It is steerable like pyzmq's steerable proxy: `TERMINATE` on its control socket (`stop()`), or
`request_stop()` from a signal handler, makes it drain: requests in flight are finished, requests
that arrive meanwhile get an `unavailable` error, then the workers exit and `run()` returns.
A worker that dies is replaced and its request gets a `worker` error reply; a request running
longer than the per-request timeout kills its worker and gets a `timeout` error reply. Requests
over the size limit get a `limit` error without reaching a worker. One log line per request;
the workers record the requests they answer, the broker those it answers itself.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import logging
import os
import secrets
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import zmq

from checker.config import Config
from checker.errors import PathcheckError
from checker.service import protocol as p
from checker.service.recorder import NullRecorder, Recorder, open_recorder
from checker.service.worker import EXIT, READY, REPLY, REQ

log = logging.getLogger("pathcheck.service")

POLL_MS = 50
MAX_START_FAILURES = 5
EXIT_WAIT_S = 5.0
REPO_ROOT = Path(__file__).resolve().parents[2]


@dataclass
class _Job:
    envelope: list[bytes]
    started: float


@dataclass
class _Worker:
    identity: bytes
    proc: subprocess.Popen
    ready: bool = False
    job: _Job | None = None


@dataclass
class _Counters:
    requests: int = 0
    errors: int = 0
    replaced: int = 0
    started: float = field(default_factory=time.time)


class Broker:
    """Front end at `bind` (e.g. `tcp://127.0.0.1:5555`; port `*` picks a free one, see
    `address`), `workers` worker processes behind it. `run()` blocks until stopped."""

    def __init__(
        self,
        config: Config,
        *,
        bind: str | None = None,
        workers: int | None = None,
        store: str | None = None,
    ) -> None:
        self.config = config
        self.limits = config.service
        self.bind = bind or self.limits.bind
        self.n_workers = workers or self.limits.workers
        self.store = store
        self.address: str | None = None
        self.started = threading.Event()
        self.ctx = zmq.Context()
        self._control_addr = f"inproc://pathcheck-broker-control-{id(self)}"
        self._stop_requested = False
        self._draining = False
        self._workers: dict[bytes, _Worker] = {}
        self._idle: deque[_Worker] = deque()
        self._ids = itertools.count(1)
        self._start_failures = 0
        self._backend_dir = ""
        self.counters = _Counters()
        self.recorder: Recorder = NullRecorder()

    # --- steering (thread- and signal-safe) ------------------------------------------------

    def request_stop(self) -> None:
        """Begin draining at the next poll (safe from a signal handler)."""
        self._stop_requested = True

    def stop(self) -> None:
        """Send TERMINATE on the control socket (from any thread)."""
        try:
            sock = self.ctx.socket(zmq.PAIR)
        except zmq.ZMQError:  # already stopped: the context is gone
            return
        sock.setsockopt(zmq.LINGER, 1000)
        sock.connect(self._control_addr)
        sock.send(b"TERMINATE")
        sock.close()

    def wait_started(self, timeout_s: float = 30.0, ready_workers: int = 0) -> str:
        """Wait until bound (and `ready_workers` workers have said READY); the front-end
        address. Raises TimeoutError."""
        deadline = time.monotonic() + timeout_s
        if not self.started.wait(timeout_s):
            raise TimeoutError("broker did not start")
        while self.ready_workers < ready_workers:
            if time.monotonic() > deadline:
                raise TimeoutError(f"{self.ready_workers} of {ready_workers} workers ready")
            time.sleep(0.02)
        return self.address

    @property
    def ready_workers(self) -> int:
        return sum(w.ready for w in list(self._workers.values()))

    def worker_pids(self) -> list[int]:
        """Process ids of the live workers."""
        return [w.proc.pid for w in list(self._workers.values())]

    def busy_pids(self) -> list[int]:
        """Process ids of the workers answering a request now."""
        return [w.proc.pid for w in list(self._workers.values()) if w.job is not None]

    # --- the loop ------------------------------------------------------------------------

    def run(self) -> None:
        """Bind, start the workers, broker until stopped, drain, stop the workers."""
        self.frontend = self.ctx.socket(zmq.ROUTER)
        self.backend = self.ctx.socket(zmq.ROUTER)
        self.control = self.ctx.socket(zmq.PAIR)
        try:
            self.frontend.setsockopt(zmq.LINGER, 2000)
            self.frontend.setsockopt(zmq.MAXMSGSIZE, 4 * self.limits.max_message_bytes + 4096)
            self.backend.setsockopt(zmq.LINGER, 0)
            self.backend.setsockopt(zmq.ROUTER_MANDATORY, 1)
            try:
                self.frontend.bind(self.bind)
            except zmq.ZMQError as err:
                raise PathcheckError(f"cannot bind {self.bind}: {err}", code="service") from err
            self.address = self.frontend.getsockopt_string(zmq.LAST_ENDPOINT)
            self.backend_addr = self._bind_backend()
            self.control.bind(self._control_addr)
            self.recorder = open_recorder(self.store)  # the requests no worker answers
            for _ in range(self.n_workers):
                self._spawn()
            log.info("listening on %s with %d workers", self.address, self.n_workers)
            self.started.set()
            self._loop()
        finally:
            self._shutdown()

    def _bind_backend(self) -> str:
        """An ipc endpoint in a fresh directory only this user can enter (workers only)."""
        self._backend_dir = tempfile.mkdtemp(prefix="pathcheck-service-")
        self.backend.bind(f"ipc://{self._backend_dir}/backend")
        return self.backend.getsockopt_string(zmq.LAST_ENDPOINT)

    def _loop(self) -> None:
        while True:
            if self._stop_requested and not self._draining:
                self._begin_drain()
            if self._draining and not any(w.job for w in self._workers.values()):
                self._from_clients()  # answer what is still queued: `unavailable`
                return
            poller = zmq.Poller()
            poller.register(self.backend, zmq.POLLIN)
            poller.register(self.control, zmq.POLLIN)
            if self._idle or self._draining:
                poller.register(self.frontend, zmq.POLLIN)
            events = dict(poller.poll(POLL_MS))
            if self.control in events and self.control.recv() == b"TERMINATE":
                self._stop_requested = True
            if self.backend in events:
                self._from_workers()
            if self.frontend in events:
                self._from_clients()
            self._check_workers()

    def _begin_drain(self) -> None:
        self._draining = True
        busy = sum(w.job is not None for w in self._workers.values())
        log.info("draining: %d request(s) in flight", busy)

    def _from_clients(self) -> None:
        while self._idle or self._draining:
            try:
                frames = self.frontend.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            envelope, body = _split(frames)
            self.counters.requests += 1
            if body is None:
                found = len(frames) - len(envelope)
                self._reject(envelope, PathcheckError(
                    f"expected one JSON frame after the envelope, found {found} frames",
                    code="request"))
            elif len(body) > self.limits.max_message_bytes:
                self._reject(envelope, PathcheckError(
                    f"request is {len(body)} bytes, the limit is "
                    f"{self.limits.max_message_bytes} bytes", code="limit"))
            elif self._draining:
                rid, op = p.peek(body)
                self._reject(envelope, PathcheckError(
                    "service is shutting down; retry another instance", code="unavailable"),
                    rid, op)
            else:
                self._dispatch(self._idle.pop(), envelope, body)  # most recently idle first

    def _dispatch(self, worker: _Worker, envelope: list[bytes], body: bytes) -> None:
        worker.job = _Job(envelope, time.monotonic())
        # unreachable: it died before we noticed; _check_workers replies to its request
        with contextlib.suppress(zmq.ZMQError):
            self.backend.send_multipart([worker.identity, REQ, body, self._stats_frame()])

    def _stats_frame(self) -> bytes:
        c = self.counters
        return json.dumps({
            "workers": len(self._workers),
            "ready": self.ready_workers,
            "busy": sum(w.job is not None for w in self._workers.values()),
            "pids": [w.proc.pid for w in self._workers.values()],
            "requests": c.requests,
            "errors": c.errors,
            "replaced": c.replaced,
            "uptime_s": round(time.time() - c.started, 3),
        }).encode()

    def _from_workers(self) -> None:
        while True:
            try:
                frames = self.backend.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            worker = self._workers.get(frames[0])
            if worker is None or len(frames) < 2:
                continue
            if frames[1] == READY:
                worker.ready = True
                self._start_failures = 0
                self._idle.append(worker)
            elif frames[1] == REPLY and len(frames) == 4 and worker.job is not None:
                job, worker.job = worker.job, None
                self._idle.append(worker)
                self._send(job.envelope, frames[2])
                try:
                    meta = json.loads(frames[3])
                except ValueError:
                    meta = {}
                if not meta.get("ok", True):
                    self.counters.errors += 1
                self._log(job.envelope, meta.get("op"), meta.get("ok"), meta.get("code"),
                          worker, time.monotonic() - job.started)

    def _check_workers(self) -> None:
        now = time.monotonic()
        for worker in list(self._workers.values()):
            code = worker.proc.poll()
            timed_out = (
                worker.job is not None and now - worker.job.started > self.limits.request_timeout_s
            )
            if code is None and not timed_out:
                continue
            if timed_out and code is None:
                worker.proc.kill()
                worker.proc.wait()
                err = PathcheckError(
                    f"request took longer than the service's {self.limits.request_timeout_s:g} s "
                    "limit; its worker was stopped", code="timeout")
            else:
                err = PathcheckError(
                    f"worker {worker.proc.pid} died (exit code {code}) while answering this "
                    "request; it has been replaced, retry", code="worker")
                if not worker.ready:
                    self._start_failures += 1
            self._remove(worker)
            shutil.rmtree(Path(self._backend_dir) / worker.identity.decode(), ignore_errors=True)
            if worker.job is not None:
                self._reject(worker.job.envelope, err, worker=worker,
                             elapsed=now - worker.job.started)
            log.warning("worker %d gone (%s)", worker.proc.pid, err.code)
            if not (self._draining or self._stop_requested):
                if self._start_failures >= MAX_START_FAILURES:
                    raise PathcheckError(
                        f"{MAX_START_FAILURES} workers in a row died before they were ready; "
                        "see the log above", code="service")
                self._spawn()
                self.counters.replaced += 1

    def _spawn(self) -> None:
        identity = f"w{next(self._ids)}-{secrets.token_hex(8)}".encode()
        cmd = [sys.executable, "-m", "checker.service.worker", self.backend_addr,
               identity.decode(), "--config-json", self.config.model_dump_json()]
        if self.store:
            cmd += ["--store", str(self.store)]
        scratch = Path(self._backend_dir) / identity.decode()  # its TMPDIR, removed with it
        scratch.mkdir()
        env = dict(os.environ, TMPDIR=str(scratch))
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO_ROOT),
                                                          env.get("PYTHONPATH")]))
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, env=env)
        self._workers[identity] = _Worker(identity, proc)

    def _remove(self, worker: _Worker) -> None:
        self._workers.pop(worker.identity, None)
        if worker in self._idle:
            self._idle.remove(worker)

    def _reject(self, envelope: list[bytes], err: PathcheckError, rid: object = None,
                op: str | None = None, worker: _Worker | None = None, elapsed: float = 0.0) -> None:
        self.counters.errors += 1
        reply = p.error_reply(err, request_id=rid, op=op)
        self._send(envelope, p.encode(reply))
        self.recorder.record(op or "?", reply, elapsed)
        self._log(envelope, op, False, err.code, worker, elapsed)

    def _send(self, envelope: list[bytes], body: bytes) -> None:
        try:
            self.frontend.send_multipart([*envelope, body])
        except zmq.ZMQError as err:  # the client has gone: nothing to answer
            log.info("reply dropped, client gone: %s", err)

    def _log(self, envelope: list[bytes], op: str | None, ok: bool | None, code: str | None,
             worker: _Worker | None, elapsed: float) -> None:
        log.info(
            "request client=%s op=%s ok=%s%s worker=%s ms=%.2f",
            envelope[0].hex()[:10] if envelope else "-", op or "?",
            "true" if ok else "false", f" code={code}" if code else "",
            worker.proc.pid if worker else "-", elapsed * 1000,
        )

    def _shutdown(self) -> None:
        workers = list(self._workers.values())
        for w in workers:
            with contextlib.suppress(zmq.ZMQError):
                self.backend.send_multipart([w.identity, EXIT])
        deadline = time.monotonic() + EXIT_WAIT_S
        for w in workers:
            try:
                w.proc.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                w.proc.kill()
                w.proc.wait()
        self._workers.clear()
        self._idle.clear()
        for sock in (getattr(self, "frontend", None), getattr(self, "backend", None),
                     getattr(self, "control", None)):
            if sock is not None:
                sock.close()
        self.ctx.term()
        if self._backend_dir:
            shutil.rmtree(self._backend_dir, ignore_errors=True)
        log.info("stopped")


def _split(frames: list[bytes]) -> tuple[list[bytes], bytes | None]:
    """Client envelope and body: REQ (and DEALER clients that mimic it) send
    `[identity, b"", body]`, plain DEALER clients `[identity, body]`."""
    if len(frames) >= 2 and frames[1] == b"":
        envelope, rest = frames[:2], frames[2:]
    else:
        envelope, rest = frames[:1], frames[1:]
    return envelope, rest[0] if len(rest) == 1 else None
