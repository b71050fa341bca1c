"""Python client of the pathcheck service (docs/protocol.md): a REQ or DEALER socket, a timeout
per attempt and retries ("lazy pirate": a REQ socket that timed out is closed and reopened, a
DEALER client drops stale replies by request id). Only silence is retried: every reply, a
refusal included (`limit`, `worker`, `crashed`, ...), is returned as it is, and a request over
`max_message_bytes` is refused here without being sent. With `curve_keys` (a key folder from
`pathcheck serve --new-keys`) the connection is encrypted and the client authenticated.

    with Client("tcp://127.0.0.1:5555") as client:
        reply = client.call("allowable", part={"path": "part.json"}, cc=[[0, 0, 0, 0, 0, 1]],
                            cutter="CUTTER/10")
"""

from __future__ import annotations

import itertools
import json
import os
import time
from pathlib import Path
from typing import Any, Literal

import zmq

from checker.errors import PathcheckError

Kind = Literal["req", "dealer"]


class Client:
    """Calls the service at `address`. Each attempt waits `timeout_s`; after a timeout (no
    reply at all) the request is sent again, up to `retries` more times; all attempts timing
    out raises PathcheckError (code `unavailable`). A request larger than `max_message_bytes`
    (the service's default limit) raises PathcheckError (code `limit`) without being sent."""

    def __init__(
        self,
        address: str,
        *,
        timeout_s: float = 60.0,
        retries: int = 2,
        kind: Kind = "req",
        max_message_bytes: int | None = None,
        curve_keys: str | Path | None = None,
    ) -> None:
        if kind not in ("req", "dealer"):
            raise ValueError(f"kind must be 'req' or 'dealer', got {kind!r}")
        self.address = address
        self.timeout_s = timeout_s
        self.retries = retries
        self.kind = kind
        if max_message_bytes is None:
            from checker.config import default_config

            max_message_bytes = default_config().service.max_message_bytes
        self.max_message_bytes = max_message_bytes
        self._curve = None
        if curve_keys is not None:
            from checker.service.keys import client_keys

            self._curve = client_keys(curve_keys)
        self._ctx = zmq.Context.instance()
        self._sock: zmq.Socket | None = None
        self._ids = itertools.count(1)
        self._prefix = f"{os.getpid()}-{id(self):x}-"

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close(linger=0)
            self._sock = None

    def call(self, op: str, **fields: Any) -> dict:
        """Send `{op, **fields}` (with a fresh `id` unless given); the reply object (`ok` true
        or false)."""
        message = {"op": op, **fields}
        message.setdefault("id", self._prefix + str(next(self._ids)))
        return self.request(message)

    def request(self, message: dict | bytes) -> dict:
        """Send one request (an object, or raw bytes sent as they are) and return the reply."""
        body = message if isinstance(message, bytes) else json.dumps(message).encode()
        if len(body) > self.max_message_bytes:
            raise PathcheckError(f"request is {len(body)} bytes, the limit is "
                                 f"{self.max_message_bytes} bytes; not sent", code="limit")
        want_id = message.get("id") if isinstance(message, dict) else None
        for _attempt in range(self.retries + 1):
            reply = self._attempt(body, want_id)
            if reply is not None:
                return reply
        raise PathcheckError(
            f"no reply from {self.address} after {self.retries + 1} attempt(s) of "
            f"{self.timeout_s:g} s", code="unavailable")

    def _socket(self) -> zmq.Socket:
        if self._sock is None:
            sock = self._ctx.socket(zmq.REQ if self.kind == "req" else zmq.DEALER)
            sock.setsockopt(zmq.LINGER, 0)
            # a send can block until a peer takes it (the CURVE test once hung in it for
            # 600 s under CI load): it must not hold the caller past its timeout either
            sock.setsockopt(zmq.SNDTIMEO, max(1, round(self.timeout_s * 1000)))
            if self._curve is not None:
                sock.curve_serverkey, sock.curve_publickey, sock.curve_secretkey = self._curve
            sock.connect(self.address)
            self._sock = sock
        return self._sock

    def _attempt(self, body: bytes, want_id: Any) -> dict | None:
        """One send and wait, together at most `timeout_s`; None on timeout (the socket is then
        reset)."""
        sock = self._socket()
        deadline = time.monotonic() + self.timeout_s
        try:
            if self.kind == "req":
                sock.send(body)
            else:
                sock.send_multipart([b"", body])
        except zmq.Again:  # no peer to take it within the timeout
            self.close()
            return None
        while True:
            if not sock.poll(max(0.0, deadline - time.monotonic()) * 1000):
                self.close()
                return None
            frames = sock.recv_multipart()
            reply = _decode(frames[-1])
            # a DEALER can see the late reply to an earlier attempt: skip it, keep waiting
            if self.kind == "req" or want_id is None or reply.get("id") == want_id:
                return reply


def raise_for_error(reply: dict) -> dict:
    """The reply itself when `ok`, else the PathcheckError it carries."""
    if reply.get("ok"):
        return reply
    error = reply.get("error") or {}
    raise PathcheckError(error.get("message", "error reply without a message"),
                         line=error.get("line"), code=error.get("code", "service"))


def _decode(frame: bytes) -> dict:
    try:
        reply = json.loads(frame)
    except ValueError as err:
        raise PathcheckError(f"reply is not valid JSON: {err}", code="protocol") from err
    if not isinstance(reply, dict) or "ok" not in reply:
        raise PathcheckError("reply is not an object with 'ok'", code="protocol")
    return reply
