"""A service worker process: a DEALER socket connected to the broker's back end, answering one
request at a time under a memory limit (RLIMIT_AS, `service.worker_memory_bytes`). Every
message it gets is answered: a request that does not validate or an op that fails becomes an
error reply, a bug an `internal` reply (traceback in the log), memory over the limit a `limit`
reply after which the worker exits to be replaced.

Back-end messages (internal to the service):
  worker -> broker  `[READY]` once; `[HEARTBEAT]` every `heartbeat_s` while idle;
                    `[STARTED, {id, op, key}]` when a request has validated and its op begins;
                    `[REPLY, reply_json, meta_json]` per request
  broker -> worker  `[REQ, request_json, context_json]`, `[HEARTBEAT]` or `[EXIT]`
`key` is the request's content hash (`request_key`); `context` holds the keys the broker
refuses (`{"refused": {key: reason}}`: requests that killed a worker); `meta` is
`{op, ok, code, elapsed_s, exit, worker, cache}` for the broker's log line and `stats`.

Run as `python -m checker.service.worker BACKEND IDENTITY [--config-json JSON] [--store PATH]
[--root DIR ...]`. SIGINT is ignored (Ctrl-C reaches the broker, which drains); SIGTERM ends the
worker after the request in hand; a worker whose broker has gone (parent changed, or no
heartbeat for LIVENESS beats) exits on its own.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import os
import resource
import signal
import time
import traceback
from collections.abc import Callable

import zmq

from checker.config import Config, default_config
from checker.errors import PathcheckError
from checker.service import protocol as p
from checker.service.ops import OPS, WorkerState
from checker.service.part_cache import PartCache, file_key
from checker.service.recorder import NullRecorder, Recorder, open_recorder
from checker.service.roots import Roots

log = logging.getLogger("pathcheck.service")

READY, REQ, REPLY, EXIT = b"READY", b"REQ", b"REPLY", b"EXIT"
HEARTBEAT, STARTED = b"HEARTBEAT", b"STARTED"
LIVENESS = 5  # heartbeats missed before the other side counts as gone


def request_key(request: p.Request, roots: Roots) -> str:
    """Content hash of a request: its fields without `id` (sha256 of the canonical JSON) and
    the bytes of every file it names that lies inside the roots."""
    digest = hashlib.sha256(request.model_dump_json(exclude={"id"}).encode())
    for name in _named_files(request):
        try:
            digest.update(file_key(roots.file(name, "", "", "").as_posix()).encode())
        except PathcheckError:  # not a readable regular file in the roots: the op says so
            digest.update(name.encode())
    return digest.hexdigest()


def _named_files(request: p.Request) -> list[str]:
    part = getattr(request, "part", None)
    names = [part.path] if isinstance(part, p.PartPath) else []
    return names + [n for n in (getattr(request, "apt_path", None),
                                getattr(request, "machine", None)) if n]


def handle(raw: bytes, state: WorkerState, recorder: Recorder,
           refused: dict[str, str] | None = None,
           started: Callable[[dict], None] | None = None) -> tuple[dict, dict]:
    """Answer one request message: `(reply, meta)`; records the request. A request whose key
    is in `refused` gets a `crashed` error without running; `started({id, op, key})` is called
    once the request has validated, before its op runs."""
    t0 = time.perf_counter()
    service = state.config.service
    state.requests += 1
    state.last_document = None
    op: str | None = None
    rid = None
    exit_after = False
    try:
        request = p.parse_request(
            raw, max_bytes=service.max_message_bytes, max_points=service.max_points,
            debug_ops=service.debug_ops,
        )
        op, rid = request.op, request.id
        key = request_key(request, state.roots)
        if refused and key in refused:
            raise PathcheckError(f"refused: an identical request (sha256 {key[:16]}) "
                                 f"{refused[key]}; it is not run again", code="crashed")
        if started is not None:
            started({"id": rid, "op": op, "key": key})
        reply = p.ok_reply(OPS[type(request)](request, state), request_id=rid, op=op)
    except PathcheckError as err:
        reply = _error(err, raw, rid, op)
    except MemoryError:
        log.warning("op %s ran out of memory; the worker exits to be replaced", op)
        cap = resource.getrlimit(resource.RLIMIT_AS)[0]
        limit = PathcheckError(
            f"the request needed more memory than a worker may use ({cap / 2**20:.0f} MiB of "
            "address space, service.worker_memory_bytes); its worker is replaced", code="limit")
        reply, exit_after = _error(limit, raw, rid, op), True
    except Exception as err:  # a bug must not kill the worker: reply, log the traceback
        log.error("internal error in op %s (id %r):\n%s", op, rid, traceback.format_exc())
        internal = PathcheckError(
            f"internal error (a bug in pathcheck; the traceback is in the service log): "
            f"{type(err).__name__}: {err}", code="internal")
        reply = _error(internal, raw, rid, op)
    elapsed = time.perf_counter() - t0
    if not reply["ok"]:
        state.errors += 1
    recorder.record(reply["op"] or "?", reply, elapsed, state.last_document, state.last_job_path)
    meta = {"op": reply["op"], "ok": reply["ok"],
            "code": (reply.get("error") or {}).get("code"), "elapsed_s": round(elapsed, 6),
            "exit": exit_after, "worker": {"requests": state.requests, "errors": state.errors},
            "cache": state.cache.stats()}
    return reply, meta


def _error(err: PathcheckError, raw: bytes, rid: object, op: str | None) -> dict:
    if op is None:
        rid, op = p.peek(raw)
    return p.error_reply(err, request_id=rid, op=op)


def limit_memory(nbytes: int) -> None:
    """Cap this process's address space (RLIMIT_AS) at `nbytes`: an allocation beyond it
    raises MemoryError instead of growing until the machine swaps."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = nbytes if hard == resource.RLIM_INFINITY else min(nbytes, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))


def run_worker(backend: str, identity: bytes, config: Config, recorder: Recorder,
               roots: Roots | None = None) -> None:
    """Serve requests from the broker at `backend` until told to exit, SIGTERM, memory over
    the limit, or the broker is gone (the parent process changed, or it stopped beating)."""
    stop = []
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    parent = os.getppid()
    beat = config.service.heartbeat_s
    state = WorkerState(config=config, cache=PartCache(config.service.part_cache_bytes),
                        roots=roots or Roots(()))
    ctx = zmq.Context()
    sock = ctx.socket(zmq.DEALER)
    sock.setsockopt(zmq.IDENTITY, identity)
    sock.setsockopt(zmq.LINGER, 1000)
    sock.connect(backend)
    sock.send_multipart([READY])
    heard = next_beat = time.monotonic()
    try:
        while not stop and os.getppid() == parent:
            now = time.monotonic()
            if now >= next_beat:
                sock.send_multipart([HEARTBEAT])
                next_beat = now + beat
            if now - heard > LIVENESS * beat:
                log.warning("worker %d: no heartbeat from the broker for %.1f s; exiting",
                            os.getpid(), now - heard)
                break
            if not sock.poll(max(0.0, next_beat - now) * 1000):
                continue
            frames = sock.recv_multipart()
            heard = time.monotonic()
            if frames[0] == EXIT:
                break
            if frames[0] != REQ or len(frames) != 3:
                continue
            reply, meta = handle(
                frames[1], state, recorder, refused=_refused(frames[2]),
                started=lambda info: sock.send_multipart([STARTED, json.dumps(info).encode()]))
            sock.send_multipart([REPLY, p.encode(reply), json.dumps(meta).encode()])
            heard = next_beat = time.monotonic()  # the broker does not beat a busy worker
            if meta["exit"]:
                break
    finally:
        sock.close()
        ctx.term()


def _refused(frame: bytes) -> dict[str, str]:
    try:
        refused = json.loads(frame).get("refused", {})
    except (ValueError, AttributeError):
        return {}
    return refused if isinstance(refused, dict) else {}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m checker.service.worker")
    parser.add_argument("backend")
    parser.add_argument("identity")
    parser.add_argument("--config-json", default=None)
    parser.add_argument("--store", default=None)
    parser.add_argument("--root", action="append", default=[])
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s worker %(message)s")
    config = Config.model_validate_json(args.config_json) if args.config_json else default_config()
    limit_memory(config.service.worker_memory_bytes)
    recorder = open_recorder(args.store) if args.store else NullRecorder()
    run_worker(args.backend, args.identity.encode(), config, recorder, Roots(args.root))


if __name__ == "__main__":
    main()
