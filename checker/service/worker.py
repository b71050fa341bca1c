"""A service worker process: a DEALER socket connected to the broker's back end, answering one
request at a time. Every message it gets is answered: a request that does not validate or an op
that fails becomes an error reply, never a dead worker.

Back-end messages (internal to the service):
  worker -> broker  `[READY]` once, then `[REPLY, reply_json, meta_json]` per request
  broker -> worker  `[REQ, request_json, broker_stats_json]` or `[EXIT]`
`meta` is `{op, ok, code, elapsed_s}` for the broker's log line.

Run as `python -m checker.service.worker BACKEND IDENTITY [--config-json JSON] [--store PATH]`.
SIGINT is ignored (Ctrl-C reaches the broker, which drains); SIGTERM ends the worker after the
request in hand; a worker whose broker has gone exits on its own.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import signal
import time
import traceback

import zmq

from checker.config import Config, default_config
from checker.errors import PathcheckError
from checker.service import protocol as p
from checker.service.cache import PartCache
from checker.service.ops import OPS, WorkerState
from checker.service.recorder import NullRecorder, Recorder, open_recorder

log = logging.getLogger("pathcheck.service")

READY, REQ, REPLY, EXIT = b"READY", b"REQ", b"REPLY", b"EXIT"
PARENT_CHECK_S = 0.5


def handle(raw: bytes, state: WorkerState, recorder: Recorder) -> tuple[dict, dict]:
    """Answer one request message: `(reply, meta)`; records the request."""
    t0 = time.perf_counter()
    service = state.config.service
    state.requests += 1
    state.last_document = None
    op: str | None = None
    rid = None
    try:
        request = p.parse_request(
            raw, max_bytes=service.max_message_bytes, max_points=service.max_points,
            debug_ops=service.debug_ops,
        )
        op, rid = request.op, request.id
        reply = p.ok_reply(OPS[type(request)](request, state), request_id=rid, op=op)
    except PathcheckError as err:
        if op is None:
            rid, op = p.peek(raw)
        reply = p.error_reply(err, request_id=rid, op=op)
    except Exception as err:  # a bug must not kill the worker: reply, log the traceback
        log.error("internal error in op %s:\n%s", op, traceback.format_exc())
        internal = PathcheckError(f"internal error: {type(err).__name__}: {err}", code="internal")
        reply = p.error_reply(internal, request_id=rid, op=op)
    elapsed = time.perf_counter() - t0
    if not reply["ok"]:
        state.errors += 1
    recorder.record(op or "?", reply, elapsed, state.last_document, state.last_job_path)
    meta = {"op": op, "ok": reply["ok"], "code": (reply.get("error") or {}).get("code"),
            "elapsed_s": round(elapsed, 6)}
    return reply, meta


def run_worker(backend: str, identity: bytes, config: Config, recorder: Recorder) -> None:
    """Serve requests from the broker at `backend` until told to exit, SIGTERM, or the broker
    (the parent process) is gone."""
    stop = []
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    parent = os.getppid()
    state = WorkerState(config=config, cache=PartCache(config.service.part_cache_bytes))
    ctx = zmq.Context()
    sock = ctx.socket(zmq.DEALER)
    sock.setsockopt(zmq.IDENTITY, identity)
    sock.setsockopt(zmq.LINGER, 1000)
    sock.connect(backend)
    sock.send_multipart([READY])
    try:
        while not stop and os.getppid() == parent:
            if not sock.poll(PARENT_CHECK_S * 1000):
                continue
            frames = sock.recv_multipart()
            if frames[0] == EXIT:
                break
            if frames[0] != REQ or len(frames) != 3:
                continue
            try:
                state.broker = json.loads(frames[2])
            except ValueError:
                state.broker = {}
            reply, meta = handle(frames[1], state, recorder)
            sock.send_multipart([REPLY, p.encode(reply), json.dumps(meta).encode()])
    finally:
        sock.close()
        ctx.term()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m checker.service.worker")
    parser.add_argument("backend")
    parser.add_argument("identity")
    parser.add_argument("--config-json", default=None)
    parser.add_argument("--store", default=None)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s worker %(message)s")
    config = Config.model_validate_json(args.config_json) if args.config_json else default_config()
    recorder = open_recorder(args.store) if args.store else NullRecorder()
    run_worker(args.backend, args.identity.encode(), config, recorder)


if __name__ == "__main__":
    main()
