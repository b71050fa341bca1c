"""The service over real sockets on 127.0.0.1: a broker with 2 worker processes, REQ and DEALER
clients, concurrency, a storm of malformed requests, a slow job, a killed worker (and the same
request refused by its content hash), a timeout, a hung worker, CURVE and the bind rule."""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest
import zmq
from brokers import running_broker, service_config, wait_busy

from checker.client import Client
from checker.errors import PathcheckError
from checker.service.broker import Broker

MAX_BYTES = 64 * 1024
TIMEOUT_S = 5.0  # long enough for a cold worker to import the library on a busy machine


def _config():
    return service_config(debug_ops=True, max_message_bytes=MAX_BYTES,
                          request_timeout_s=TIMEOUT_S, max_points=1000)


@pytest.fixture(scope="module")
def broker():
    with running_broker(_config()) as b:
        assert b.address.startswith("tcp://127.0.0.1:")
        yield b


def _client(b: Broker, **kw) -> Client:
    kw.setdefault("timeout_s", 10.0)
    return Client(b.address, **kw)


def test_ping_req_and_dealer(broker):
    for kind in ("req", "dealer"):
        with _client(broker, kind=kind) as c:
            reply = c.call("ping", id="abc")
        assert reply["ok"] is True and reply["pong"] is True
        assert reply["id"] == "abc" and reply["op"] == "ping" and reply["v"] == 1
        assert reply["broker"] == os.getpid()  # answered by the broker, not a worker


def test_plain_dealer_without_delimiter_gets_a_reply_in_the_same_shape(broker):
    sock = zmq.Context.instance().socket(zmq.DEALER)
    sock.connect(broker.address)
    try:
        for k in range(3):
            sock.send(json.dumps({"op": "ping", "id": k}).encode())
        replies = []
        while len(replies) < 3 and sock.poll(10_000):
            frames = sock.recv_multipart()
            assert len(frames) == 1
            replies.append(json.loads(frames[0]))
    finally:
        sock.close(linger=0)
    assert sorted(r["id"] for r in replies) == [0, 1, 2] and all(r["ok"] for r in replies)


def test_stats_reports_broker_and_workers(broker):
    with _client(broker) as c:
        c.call("sleep", seconds=0)
        c.call("sleep", seconds=0)
        reply = c.call("stats")
    assert reply["ok"]
    assert reply["broker"]["workers"] == 2 and reply["broker"]["pid"] == os.getpid()
    assert sorted(reply["broker"]["pids"]) == sorted(broker.worker_pids())
    assert sorted(w["pid"] for w in reply["workers"]) == sorted(broker.worker_pids())
    answered = [w for w in reply["workers"] if "cache" in w]
    assert answered and all(w["worker"]["requests"] >= 1 for w in answered)
    assert all(w["cache"]["entries"] == 0 or w["cache"]["bytes"] > 0 for w in answered)


def test_8_clients_x_25_requests(broker):
    """8 concurrent clients (half REQ, half DEALER) x 25 requests: every reply is the answer to
    its own request (id, op, and the sleep's echo)."""

    def run(k: int) -> list[tuple[dict, dict]]:
        pairs = []
        with _client(broker, kind="req" if k % 2 else "dealer") as c:
            for i in range(25):
                if i % 5 == 4:
                    req = {"op": "sleep", "seconds": 0.001 * (k + 1), "id": f"{k}-{i}"}
                elif i % 5 == 3:
                    req = {"op": "stats", "id": f"{k}-{i}"}
                else:
                    req = {"op": "ping", "id": f"{k}-{i}"}
                pairs.append((req, c.request(req)))
        return pairs

    with ThreadPoolExecutor(8) as pool:
        results = list(pool.map(run, range(8)))
    pairs = [pair for client in results for pair in client]
    assert len(pairs) == 200
    workers_used = set()
    for req, reply in pairs:
        assert reply["ok"] is True, reply
        assert reply["id"] == req["id"] and reply["op"] == req["op"]
        if req["op"] == "sleep":
            assert reply["slept"] == req["seconds"]
            workers_used.add(reply["worker"])
    assert workers_used == set(broker.worker_pids())  # the load was balanced over both


def _malformed() -> list[tuple[bytes, set[str]]]:
    """(request bytes, acceptable error codes): 200 malformed requests of every kind."""
    nan_cc = '{"op":"allowable","part":{"path":"p.json"},"cc":[[0,0,NaN,0,0,1]],"cutter":"C"}'
    kinds: list[tuple[bytes, set[str]]] = [
        (b"{not json", {"json"}),
        (b"", {"json"}),
        (b"\xff\xfe\x00garbage", {"json"}),
        (b'{"op": "ping"', {"json"}),
        (b"[1, 2, 3]", {"request"}),
        (b'"ping"', {"request"}),
        (b"{}", {"op"}),
        (b'{"op": "launch_missiles"}', {"op"}),
        (b'{"op": 7}', {"op"}),
        (b'{"op": "sleep", "seconds": 0}', set()),  # debug op is on here: not malformed
        (b'{"op": "ping", "v": 2}', {"version"}),
        (b'{"op": "ping", "extra": 1}', {"request"}),
        (b'{"op": "allowable", "part": {"path": "p.json"}, "cc": "lots", "cutter": "C"}',
         {"request"}),
        (b'{"op": "allowable", "part": {"path": "p.json"}, "cc": [[1,2,3]], "cutter": "C"}',
         {"request"}),
        (b'{"op": "allowable", "part": {"path": "p.json"}, "cc": [["1",2,3,0,0,1]],'
         b' "cutter": "C"}', {"request"}),
        (b'{"op": "allowable", "part": 5, "cc": [[0,0,0,0,0,1]], "cutter": "C"}', {"request"}),
        (b'{"op": "allowable", "part": {"path": "p.json"}, "cc": [], "cutter": "C"}',
         {"request"}),
        (nan_cc.encode(), {"request"}),
        (nan_cc.replace("NaN", "Infinity").encode(), {"request"}),
        (nan_cc.replace("NaN", "1e999").encode(), {"request"}),
        (json.dumps({"op": "allowable", "part": {"path": "p.json"}, "cutter": "C",
                     "cc": [[0, 0, 0, 0, 0, 1]] * 1001}).encode(), {"limit"}),
        (json.dumps({"op": "allowable", "part": {"path": "/no/such/part.json"},
                     "cc": [[0, 0, 0, 0, 0, 1]], "cutter": "CUTTER/10"}).encode(), {"forbidden"}),
        (json.dumps({"op": "allowable", "part": {"path": "no/such/part.json"},
                     "cc": [[0, 0, 0, 0, 0, 1]], "cutter": "CUTTER/10"}).encode(), {"part"}),
        (json.dumps({"op": "allowable", "part": {"path": "/no/such/part.json"},
                     "cc": [[0, 0, 0, 0, 0, 0]], "cutter": "CUTTER/10"}).encode(), {"request"}),
        (json.dumps({"op": "check", "apt": "PARTNO T\nCUTTER/10\nGOTO/1,2,$\n",
                     "part": {"path": "/no/such/part.step"}}).encode(), {"forbidden"}),
        (json.dumps({"op": "check", "apt": "PARTNO T\nCUTTER/10\nGOTO/1,2,$\n"}).encode(),
         {"parse", "input", "unavailable"}),
        (json.dumps({"op": "check", "apt_path": "/no/such/job.apt"}).encode(), {"forbidden"}),
        (json.dumps({"op": "check", "apt_path": "no/such/job.apt"}).encode(), {"input"}),
        (json.dumps({"op": "check"}).encode(), {"request"}),
        (json.dumps({"op": "ping", "pad": "x" * (MAX_BYTES + 1)}).encode(), {"limit"}),
    ]
    kinds = [k for k in kinds if k[1]]
    return [kinds[i % len(kinds)] for i in range(200)]


def test_200_malformed_requests_each_get_a_structured_error(broker):
    pids = sorted(broker.worker_pids())
    requests = _malformed()
    with _client(broker, kind="dealer", retries=0) as c:
        replies = [c.request(raw) for raw, _ in requests]
    for (raw, codes), reply in zip(requests, replies, strict=True):
        assert reply["ok"] is False, raw[:80]
        assert set(reply["error"]) <= {"code", "message", "line"}
        assert reply["error"]["code"] in codes, (raw[:80], reply)
        assert len(reply["error"]["message"]) > 10
    # the envelope itself malformed: two body frames from a raw DEALER
    sock = zmq.Context.instance().socket(zmq.DEALER)
    sock.connect(broker.address)
    sock.send_multipart([b"", b'{"op":"ping"}', b"second frame"])
    assert sock.poll(10_000)
    frames = sock.recv_multipart()
    sock.close(linger=0)
    assert json.loads(frames[-1])["error"]["code"] == "request"
    with _client(broker) as c:
        assert c.call("ping")["ok"] is True
    assert sorted(broker.worker_pids()) == pids  # no worker died on the way


def test_error_replies_echo_the_request_id(broker):
    with _client(broker) as c:
        reply = c.request(b'{"op": "allowable", "id": 42, "cc": 1}')
    assert reply["id"] == 42 and reply["op"] == "allowable"
    assert reply["error"]["message"].startswith("field 'part'")


def test_a_slow_job_does_not_block_the_others(broker):
    with _client(broker, kind="dealer") as slow, ThreadPoolExecutor(1) as pool:
        pending = pool.submit(slow.call, "sleep", seconds=1.0)
        time.sleep(0.1)
        with _client(broker) as fast:
            t0 = time.perf_counter()
            for _ in range(5):
                assert fast.call("ping")["ok"]
            fast_s = time.perf_counter() - t0
        assert not pending.done()
        assert fast_s < 0.8
        assert pending.result(10)["slept"] == 1.0


def test_worker_killed_mid_request_gets_error_then_the_same_request_is_refused(broker):
    """A killed worker: its request gets `worker` with its id, the client does not re-send it,
    and the same request sent again (a new id) is refused by content hash: `crashed`."""
    requests_before = broker.counters.requests
    with _client(broker, retries=2) as c, ThreadPoolExecutor(1) as pool:
        pending = pool.submit(c.call, "sleep", seconds=1.5, id="victim-1")
        victim = wait_busy(broker)
        os.kill(victim, signal.SIGKILL)
        reply = pending.result(10)
        assert reply["ok"] is False and reply["error"]["code"] == "worker"
        assert reply["id"] == "victim-1" and reply["op"] == "sleep"
        assert f"worker {victim} died (signal SIGKILL)" in reply["error"]["message"]
        assert broker.counters.requests == requests_before + 1  # not re-sent
        again = c.call("sleep", seconds=1.5, id="victim-2")
        assert again["ok"] is False and again["error"]["code"] == "crashed"
        assert again["id"] == "victim-2" and "took worker" in again["error"]["message"]
        other = c.call("sleep", seconds=0.25)  # another request runs as usual
        assert other["ok"] is True and other["slept"] == 0.25
    broker.wait_started(30, ready_workers=2)
    assert len(broker.worker_pids()) == 2 and victim not in broker.worker_pids()
    with _client(broker) as c:
        assert all(c.call("ping")["ok"] for _ in range(10))


def test_request_over_the_time_limit_gets_timeout_error(broker):
    with _client(broker, retries=0) as c:
        t0 = time.perf_counter()
        reply = c.call("sleep", seconds=30)
        took = time.perf_counter() - t0
        assert reply["ok"] is False and reply["error"]["code"] == "timeout"
        assert reply["id"] is not None and reply["op"] == "sleep"
        assert TIMEOUT_S <= took < TIMEOUT_S + 2
        assert c.call("ping")["ok"]
    broker.wait_started(30, ready_workers=2)


def test_client_gives_up_after_retries_when_nobody_answers():
    """A ROUTER that never answers: each attempt times out, the REQ socket is reset and the
    request sent again; after 1 + retries attempts the client raises `unavailable`."""
    ctx = zmq.Context.instance()
    silent = ctx.socket(zmq.ROUTER)
    silent.bind("tcp://127.0.0.1:*")
    try:
        address = silent.getsockopt_string(zmq.LAST_ENDPOINT)
        with Client(address, timeout_s=0.2, retries=2) as c, pytest.raises(PathcheckError) as exc:
            c.call("ping")
        assert exc.value.code == "unavailable" and "3 attempt" in str(exc.value)
        seen = 0
        while silent.poll(200):
            silent.recv_multipart()
            seen += 1
        assert seen == 3
    finally:
        silent.close(linger=0)


def test_client_retry_after_a_lost_reply_succeeds():
    """The server drops the first attempt and answers the second."""
    ctx = zmq.Context.instance()
    server = ctx.socket(zmq.ROUTER)
    server.bind("tcp://127.0.0.1:*")
    address = server.getsockopt_string(zmq.LAST_ENDPOINT)

    def serve_second() -> None:
        for attempt in range(2):
            if not server.poll(5000):
                return
            *envelope, body = server.recv_multipart()
            if attempt == 1:
                rid = json.loads(body)["id"]
                server.send_multipart([*envelope, json.dumps({"ok": True, "id": rid}).encode()])

    thread = threading.Thread(target=serve_second)
    thread.start()
    try:
        with Client(address, timeout_s=0.3, retries=1) as c:
            assert c.call("ping")["ok"] is True
    finally:
        thread.join(10)
        server.close(linger=0)
