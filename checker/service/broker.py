"""The service's broker: a ROUTER front end for clients (REQ or DEALER), a ROUTER back end for
worker processes, and the load-balancing loop between them (pyzmq's load-balancing broker
pattern: a request goes only to an idle worker, so one slow job never blocks the others). The
most recently idle worker is taken first, so a client calling again for the same part finds it
in that worker's part cache.

The broker reads every request at once: `ping`, `stats` and malformed small requests are
answered by the broker itself (never queued behind busy workers); the others wait in a bounded
queue for an idle worker (`busy` when it is full). Broker and idle workers exchange heartbeats
(pyzmq's paranoid pirate pattern): a worker silent for LIVENESS beats is hung, killed and
replaced. A worker that dies is replaced and its request gets a `worker` error; a request
running longer than the per-request timeout kills its worker and gets a `timeout` error;
either way the request's content hash is remembered and the same request is refused next
time (`crashed`) instead of taking another worker down. Requests over the size limit get a
`limit` error without reaching a worker. Every error reply carries the request's id.

It is steerable like pyzmq's steerable proxy: `TERMINATE` on its control socket (`stop()`), or
`request_stop()` from a signal handler, makes it drain: requests in flight are finished, queued
ones and those that arrive meanwhile get an `unavailable` error, then the workers exit and
`run()` returns. The front end binds beyond loopback only with CURVE keys (`curve_keys`,
`checker.service.keys`) or `insecure=True`. One log line per request.
"""

from __future__ import annotations

import contextlib
import ipaddress
import itertools
import json
import logging
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import OrderedDict, deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zmq

from checker.config import Config
from checker.errors import PathcheckError
from checker.service import protocol as p
from checker.service.recorder import BackgroundRecorder
from checker.service.roots import Roots
from checker.service.worker import EXIT, HEARTBEAT, LIVENESS, READY, REPLY, REQ, STARTED

log = logging.getLogger("pathcheck.service")

POLL_MS = 50
MAX_START_FAILURES = 5
START_TIMEOUT_S = 120.0  # a worker not READY by then is hung at start
EXIT_WAIT_S = 5.0
BROKER_PARSE_BYTES = 4096  # requests up to this size are validated by the broker itself
MAX_QUEUED = 10_000
MAX_REFUSED = 256  # content hashes of requests that took a worker down
REPO_ROOT = Path(__file__).resolve().parents[2]
NETWORK_TRANSPORTS = ("tcp", "ws", "wss", "udp", "pgm", "epgm", "norm", "tipc", "vmci")


@dataclass
class _Job:
    envelope: list[bytes]
    body: bytes
    started: float
    id: Any = None
    op: str | None = None
    key: str | None = None  # content hash, once the worker has said STARTED
    known: bool = False


@dataclass
class _Worker:
    identity: bytes
    proc: subprocess.Popen
    spawned: float = field(default_factory=time.monotonic)
    seen: float = field(default_factory=time.monotonic)
    ready: bool = False
    retiring: bool = False  # it answered and exits (memory over the limit): not given work
    job: _Job | None = None
    meta: dict = field(default_factory=dict)  # its counters and cache, from its last reply


@dataclass
class _Counters:
    requests: int = 0
    errors: int = 0
    replaced: int = 0
    started: float = field(default_factory=time.time)


class Broker:
    """Front end at `bind` (e.g. `tcp://127.0.0.1:5555`; port `*` picks a free one, see
    `address`), `workers` worker processes behind it reading files only inside `roots`;
    requests recorded in `store`, pruned to `keep_days` days. `run()` blocks until stopped."""

    def __init__(
        self,
        config: Config,
        *,
        bind: str | None = None,
        workers: int | None = None,
        store: str | None = None,
        roots: Roots | None = None,
        curve_keys: str | Path | None = None,
        insecure: bool = False,
        keep_days: float | None = None,
    ) -> None:
        self.config = config
        self.limits = config.service
        self.bind = bind or self.limits.bind
        self.n_workers = workers or self.limits.workers
        self.store = store
        self.roots = roots or Roots(())
        self.curve_keys = curve_keys
        self.insecure = insecure
        self.keep_days = keep_days
        self.address: str | None = None
        self.started = threading.Event()
        self.ctx = zmq.Context()
        self._control_addr = f"inproc://pathcheck-broker-control-{id(self)}"
        self._stop_requested = False
        self._draining = False
        self._workers: dict[bytes, _Worker] = {}
        self._idle: deque[_Worker] = deque()
        self._queue: deque[tuple[list[bytes], bytes]] = deque()
        self._queued_bytes = 0
        self._refused: OrderedDict[str, str] = OrderedDict()
        self._ids = itertools.count(1)
        self._start_failures = 0
        self._backend_dir = ""
        self._next_beat = 0.0
        self._auth = None
        self.counters = _Counters()
        self.recorder: BackgroundRecorder | None = None

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
        return sum(w.ready and not w.retiring for w in list(self._workers.values()))

    def worker_pids(self) -> list[int]:
        """Process ids of the live workers."""
        return [w.proc.pid for w in list(self._workers.values())]

    def busy_pids(self) -> list[int]:
        """Process ids of the workers running a request's op now (it has said STARTED)."""
        return [w.proc.pid for w in list(self._workers.values()) if w.job and w.job.key]

    # --- the loop ------------------------------------------------------------------------

    def run(self) -> None:
        """Bind, start the workers, broker until stopped, drain, stop the workers."""
        check_bind(self.bind, curve=self.curve_keys is not None, insecure=self.insecure)
        self.frontend = self.ctx.socket(zmq.ROUTER)
        self.backend = self.ctx.socket(zmq.ROUTER)
        self.control = self.ctx.socket(zmq.PAIR)
        try:
            self.frontend.setsockopt(zmq.LINGER, 2000)
            self.frontend.setsockopt(zmq.MAXMSGSIZE, 4 * self.limits.max_message_bytes + 4096)
            if self.curve_keys is not None:
                self._curve(self.curve_keys)
            self.backend.setsockopt(zmq.LINGER, 0)
            self.backend.setsockopt(zmq.ROUTER_MANDATORY, 1)
            try:
                self.frontend.bind(self.bind)
            except zmq.ZMQError as err:
                raise PathcheckError(f"cannot bind {self.bind}: {err}", code="service") from err
            self.address = self.frontend.getsockopt_string(zmq.LAST_ENDPOINT)
            self.backend_addr = self._bind_backend()
            self.control.bind(self._control_addr)
            self.recorder = BackgroundRecorder(self.store, self.keep_days)
            for _ in range(self.n_workers):
                self._spawn()
            log.info("listening on %s with %d workers%s", self.address, self.n_workers,
                     " (CURVE)" if self.curve_keys is not None else "")
            self.started.set()
            self._loop()
        finally:
            self._shutdown()

    def _curve(self, folder: str | Path) -> None:
        """CURVE on the front end; a ZAP handler (pyzmq's ThreadAuthenticator) lets in only
        the clients whose public keys are in the key folder's `clients/`."""
        from zmq.auth.thread import ThreadAuthenticator

        from checker.service.keys import server_keys

        public, secret, clients = server_keys(folder)
        self._auth = ThreadAuthenticator(self.ctx, log=logging.getLogger("pathcheck.zap"))
        self._auth.start()
        self._auth.configure_curve(domain="*", location=str(clients))
        self.frontend.curve_secretkey = secret
        self.frontend.curve_publickey = public
        self.frontend.curve_server = True

    def _bind_backend(self) -> str:
        """An ipc endpoint in a fresh directory only this user can enter (workers only)."""
        self._backend_dir = tempfile.mkdtemp(prefix="pathcheck-service-")
        self.backend.bind(f"ipc://{self._backend_dir}/backend")
        return self.backend.getsockopt_string(zmq.LAST_ENDPOINT)

    def _loop(self) -> None:
        poller = zmq.Poller()
        for sock in (self.backend, self.control, self.frontend):
            poller.register(sock, zmq.POLLIN)
        while True:
            if self._stop_requested and not self._draining:
                self._begin_drain()
            if self._draining and not any(w.job for w in self._workers.values()):
                self._from_clients()  # answer what is still arriving: `unavailable`
                return
            events = dict(poller.poll(POLL_MS))
            if self.control in events and self.control.recv() == b"TERMINATE":
                self._stop_requested = True
            if self.backend in events:
                self._from_workers()
            if self.frontend in events:
                self._from_clients()
            self._dispatch_queued()
            self._check_workers()
            self._beat()

    def _begin_drain(self) -> None:
        self._draining = True
        busy = sum(w.job is not None for w in self._workers.values())
        log.info("draining: %d request(s) in flight, %d queued", busy, len(self._queue))
        while self._queue:
            envelope, body = self._queue.popleft()
            self._refuse_unavailable(envelope, body)
        self._queued_bytes = 0

    def _from_clients(self) -> None:
        for _ in range(1000):  # then serve the workers again
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
                    f"{self.limits.max_message_bytes} bytes", code="limit"), *p.peek(body))
            elif self._draining:
                self._refuse_unavailable(envelope, body)
            elif len(body) > BROKER_PARSE_BYTES or not self._answer_small(envelope, body):
                self._enqueue(envelope, body)

    def _answer_small(self, envelope: list[bytes], body: bytes) -> bool:
        """Answer a small request here when it is `ping`, `stats` or malformed; False: it is
        work for a worker."""
        t0 = time.perf_counter()
        try:
            request = p.parse_request(body, max_bytes=self.limits.max_message_bytes,
                                      max_points=self.limits.max_points,
                                      debug_ops=self.limits.debug_ops)
        except PathcheckError as err:
            self._reject(envelope, err, *p.peek(body))
            return True
        if isinstance(request, p.PingRequest):
            result = {"pong": True, "broker": os.getpid(), "time": time.time()}
        elif isinstance(request, p.StatsRequest):
            result = self._stats()
        else:
            return False
        reply = p.ok_reply(result, request_id=request.id, op=request.op)
        self._send(envelope, p.encode(reply))
        elapsed = time.perf_counter() - t0
        self.recorder.record(request.op, reply, elapsed)
        self._log(envelope, request.op, request.id, True, None, None, elapsed)
        return True

    def _stats(self) -> dict:
        now = time.monotonic()
        c = self.counters
        workers = []
        for w in self._workers.values():
            job = w.job
            workers.append({
                "pid": w.proc.pid, "ready": w.ready, "busy": job is not None,
                "request": None if job is None else {
                    "id": job.id, "op": job.op, "running_s": round(now - job.started, 3)},
                **w.meta,
            })
        return {
            "protocol": p.PROTOCOL_VERSION,
            "broker": {
                "pid": os.getpid(),
                "workers": len(self._workers),
                "ready": self.ready_workers,
                "busy": sum(w.job is not None for w in self._workers.values()),
                "queued": len(self._queue),
                "pids": [w.proc.pid for w in self._workers.values()],
                "requests": c.requests,
                "errors": c.errors,
                "replaced": c.replaced,
                "refused_keys": len(self._refused),
                "uptime_s": round(time.time() - c.started, 3),
            },
            "workers": workers,
        }

    def _enqueue(self, envelope: list[bytes], body: bytes) -> None:
        room = 4 * self.limits.max_message_bytes - self._queued_bytes
        if len(self._queue) >= MAX_QUEUED or len(body) > room:
            self._reject(envelope, PathcheckError(
                f"the service is busy: {len(self._queue)} requests ({self._queued_bytes} bytes) "
                "are waiting for a worker; retry later", code="busy"), *p.peek(body))
            return
        self._queue.append((envelope, body))
        self._queued_bytes += len(body)

    def _dispatch_queued(self) -> None:
        while self._idle and self._queue and not self._draining:
            envelope, body = self._queue.popleft()
            self._queued_bytes -= len(body)
            worker = self._idle.pop()  # most recently idle first
            worker.job = _Job(envelope, body, time.monotonic())
            context = json.dumps({"refused": dict(self._refused)}).encode()
            # unreachable: it died before we noticed; _check_workers replies to its request
            with contextlib.suppress(zmq.ZMQError):
                self.backend.send_multipart([worker.identity, REQ, body, context])

    def _from_workers(self) -> None:
        while True:
            try:
                frames = self.backend.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            worker = self._workers.get(frames[0])
            if worker is None or len(frames) < 2:
                continue
            worker.seen = time.monotonic()
            kind = frames[1]
            if kind == READY and not worker.ready:
                worker.ready = True
                self._start_failures = 0
                self._idle.append(worker)
            elif kind == STARTED and len(frames) == 3 and worker.job is not None:
                with contextlib.suppress(ValueError, AttributeError):
                    info = json.loads(frames[2])
                    job = worker.job
                    job.id, job.op, job.key, job.known = info["id"], info["op"], info["key"], True
            elif kind == REPLY and len(frames) == 4 and worker.job is not None:
                self._replied(worker, frames[2], frames[3])

    def _replied(self, worker: _Worker, body: bytes, meta_frame: bytes) -> None:
        job, worker.job = worker.job, None
        self._send(job.envelope, body)
        try:
            meta = json.loads(meta_frame)
        except ValueError:
            meta = {}
        worker.meta = {k: meta[k] for k in ("worker", "cache") if k in meta}
        if meta.get("exit"):
            worker.retiring = True  # it exits now; _check_workers replaces it
        else:
            self._idle.append(worker)
        if not meta.get("ok", True):
            self.counters.errors += 1
        rid = job.id if job.known else p.peek(job.body)[0]
        self._log(job.envelope, meta.get("op"), rid, meta.get("ok"), meta.get("code"), worker,
                  time.monotonic() - job.started)

    def _check_workers(self) -> None:
        now = time.monotonic()
        silent = LIVENESS * self.limits.heartbeat_s
        for worker in list(self._workers.values()):
            code = worker.proc.poll()
            job = worker.job
            if code is None:
                if job is not None and now - job.started > self.limits.request_timeout_s:
                    why = f"ran over the service's {self.limits.request_timeout_s:g} s limit"
                    err = PathcheckError(f"request {why}; its worker was stopped and replaced, "
                                         "and this request is refused if sent again",
                                         code="timeout")
                elif job is None and worker.ready and not worker.retiring \
                        and now - worker.seen > silent:
                    why, err = f"hung: no heartbeat for {now - worker.seen:.1f} s", None
                elif not worker.ready and now - worker.spawned > START_TIMEOUT_S:
                    why, err = "hung at start", None
                    self._start_failures += 1
                else:
                    continue
                worker.proc.kill()
                code = worker.proc.wait()
            else:
                why = f"died ({_exit(code)})"
                err = PathcheckError(
                    f"worker {worker.proc.pid} {why} while answering this request; it has been "
                    "replaced, and this request is refused if sent again", code="worker")
                if not worker.ready:
                    self._start_failures += 1
            self._remove(worker)
            shutil.rmtree(Path(self._backend_dir) / worker.identity.decode(), ignore_errors=True)
            if job is not None:
                self._lost(worker, job, err, why)
            log.log(logging.INFO if worker.retiring else logging.WARNING,
                    "worker %d gone: %s", worker.proc.pid, "retired" if worker.retiring else why)
            if not (self._draining or self._stop_requested):
                if self._start_failures >= MAX_START_FAILURES:
                    raise PathcheckError(
                        f"{MAX_START_FAILURES} workers in a row died before they were ready; "
                        "see the log above", code="service")
                self._spawn()
                self.counters.replaced += 1

    def _lost(self, worker: _Worker, job: _Job, err: PathcheckError, why: str) -> None:
        """Answer the request a worker took down with it; remember its content hash."""
        if job.key is not None:
            stamp = time.strftime("%Y-%m-%d %H:%M:%S")
            self._refused[job.key] = f"took worker {worker.proc.pid} down at {stamp}: {why}"
            while len(self._refused) > MAX_REFUSED:
                self._refused.popitem(last=False)
        rid, op = (job.id, job.op) if job.known else p.peek(job.body)
        self._reject(job.envelope, err, rid, op, worker=worker,
                     elapsed=time.monotonic() - job.started)

    def _beat(self) -> None:
        now = time.monotonic()
        if now < self._next_beat:
            return
        self._next_beat = now + self.limits.heartbeat_s
        for worker in list(self._idle):
            with contextlib.suppress(zmq.ZMQError):
                self.backend.send_multipart([worker.identity, HEARTBEAT])

    def _spawn(self) -> None:
        identity = f"w{next(self._ids)}-{secrets.token_hex(8)}".encode()
        cmd = [sys.executable, "-m", "checker.service.worker", self.backend_addr,
               identity.decode(), "--config-json", self.config.model_dump_json(),
               *self.roots.args()]
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

    def _refuse_unavailable(self, envelope: list[bytes], body: bytes) -> None:
        self._reject(envelope, PathcheckError(
            "service is shutting down; retry another instance", code="unavailable"), *p.peek(body))

    def _reject(self, envelope: list[bytes], err: PathcheckError, rid: object = None,
                op: str | None = None, worker: _Worker | None = None, elapsed: float = 0.0) -> None:
        self.counters.errors += 1
        reply = p.error_reply(err, request_id=rid, op=op)
        self._send(envelope, p.encode(reply))
        self.recorder.record(op or "?", reply, elapsed)
        self._log(envelope, op, rid, False, err.code, worker, elapsed)

    def _send(self, envelope: list[bytes], body: bytes) -> None:
        try:
            self.frontend.send_multipart([*envelope, body])
        except zmq.ZMQError as err:  # the client has gone: nothing to answer
            log.info("reply dropped, client gone: %s", err)

    def _log(self, envelope: list[bytes], op: str | None, rid: object, ok: bool | None,
             code: str | None, worker: _Worker | None, elapsed: float) -> None:
        log.info(
            "request client=%s op=%s id=%s ok=%s%s worker=%s ms=%.2f",
            envelope[0].hex()[:10] if envelope else "-", op or "?", json.dumps(rid)[:60],
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
        if self._auth is not None:
            self._auth.stop()
        for sock in (getattr(self, "frontend", None), getattr(self, "backend", None),
                     getattr(self, "control", None)):
            if sock is not None:
                sock.close()
        self.ctx.term()
        if self.recorder is not None:
            self.recorder.close()
        if self._backend_dir:
            shutil.rmtree(self._backend_dir, ignore_errors=True)
        log.info("stopped")


def check_bind(bind: str, *, curve: bool, insecure: bool) -> None:
    """Refuse a front end reachable from other machines without CURVE (unless `insecure`):
    of the network transports only tcp://, ws:// and wss:// on a loopback address are local
    (ipc://, inproc:// are; an unknown transport fails at bind)."""
    scheme, _, rest = bind.partition("://")
    if curve or insecure or scheme not in NETWORK_TRANSPORTS:
        return
    host = rest.split("/", 1)[0].rsplit(":", 1)[0].strip("[]")
    try:
        local = host == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:  # `*`, an interface or a host name
        local = False
    if scheme not in ("tcp", "ws", "wss") or not local:
        raise PathcheckError(
            f"{bind} may be reachable from other machines: give --curve-keys DIR (keys from "
            "`pathcheck serve --new-keys DIR`) or --insecure, or bind tcp://127.0.0.1:PORT",
            code="usage")


def _exit(code: int) -> str:
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"signal {signal.Signals(-code).name}"
        return f"signal {-code}"
    return f"exit code {code}"


def _split(frames: list[bytes]) -> tuple[list[bytes], bytes | None]:
    """Client envelope and body: REQ (and DEALER clients that mimic it) send
    `[identity, b"", body]`, plain DEALER clients `[identity, body]`."""
    if len(frames) >= 2 and frames[1] == b"":
        envelope, rest = frames[:2], frames[2:]
    else:
        envelope, rest = frames[:1], frames[1:]
    return envelope, rest[0] if len(rest) == 1 else None
