"""The service under attack and under faults, over real sockets with real worker processes:
500 hostile requests from 6 concurrent clients, paths outside the roots, devices, FIFOs and
symlinks, file contents never echoed, a worker killed mid-request, a request that took a
worker down refused by its content hash, memory over the worker's limit, a hung worker, ping
answered by the broker while every worker is busy, CURVE, and SIGTERM with requests in flight
(every request answered exactly once, with its id)."""

from __future__ import annotations

import json
import logging
import os
import re
import signal
import statistics
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import zmq
from brokers import running_broker, service_config, wait_busy

from checker.client import Client
from checker.errors import PathcheckError
from checker.service.broker import Broker

REPO = Path(__file__).resolve().parents[1]
MAX_BYTES = 64 * 1024
SECRET = "s3cret-token-4711"
TINY_APT = "PARTNO T\n{pprint}CUTTER/10\nFEDRAT/100\nGOTO/0,0,0\nGOTO/1,0,0\nFINI\n"


def _config():
    return service_config(debug_ops=True, max_message_bytes=MAX_BYTES, request_timeout_s=30.0,
                          max_points=1000, heartbeat_s=0.5, worker_memory_bytes=1000 * 2**20)


def _surfaces(n: int, size: float) -> dict:
    """geomdl exchange JSON: `n` flat bicubic patches of `size` mm (each sampled to the
    per-surface cap: n = 3 runs a second or two, n = 40 needs ~3 GB of address space)."""
    xs = [-size + 2 * size * k / 3 for k in range(4)]
    knots = [0, 0, 0, 0, 1, 1, 1, 1]
    data = [{"type": "spline", "rational": False, "degree_u": 3, "degree_v": 3,
             "knotvector_u": knots, "knotvector_v": knots, "size_u": 4, "size_v": 4,
             "control_points": {"points": [[x, y, float(k)] for x in xs for y in xs]}}
            for k in range(n)]
    return {"shape": {"type": "surface", "count": n, "data": data}}


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    """The service's one root: a plane part, a non-CL file holding a secret, a folder, a FIFO,
    symlinks out of the root (to /etc/passwd and /dev/zero), one inside it and a loop."""
    folder = tmp_path_factory.mktemp("root")
    (folder / "plane.json").write_text(json.dumps(_surfaces(1, 50.0)))
    (folder / "secret.txt").write_text(f"password = {SECRET}\nroot:x:0:0\n")
    (folder / "sub").mkdir()
    os.mkfifo(folder / "pipe.json")
    (folder / "passwd.apt").symlink_to("/etc/passwd")
    (folder / "zero.json").symlink_to("/dev/zero")
    (folder / "alias.json").symlink_to(folder / "plane.json")
    (folder / "loop.json").symlink_to(folder / "loop.json")
    return folder


@pytest.fixture(scope="module")
def broker(root):
    with running_broker(_config(), roots=[root]) as b:
        yield b


def _client(b: Broker, **kw) -> Client:
    kw.setdefault("timeout_s", 30.0)
    kw.setdefault("retries", 0)
    return Client(b.address, **kw)


def _wait(predicate, timeout_s: float = 20.0, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.02)


# --- 500 hostile requests ------------------------------------------------------------------


def _allowable(part: dict, **extra) -> dict:
    return {"op": "allowable", "part": part, "cc": [[0, 0, 0, 0, 0, 1]], "cutter": "CUTTER/10",
            **extra}


def _kinds() -> list[tuple[object, set[str]]]:
    """(request, acceptable codes; `ok` for a valid request): a dict gets an `id` when sent;
    bytes are sent as they are (their id, if any, in BYTE_IDS)."""
    nan = b'{"op":"allowable","part":{"path":"plane.json"},"cc":[[0,0,NaN,0,0,1]],"cutter":"C"'
    return [
        (b"{not json", {"json"}),
        (b"", {"json"}),
        (b"\xff\xfe\x00garbage", {"json"}),
        (b"[1, 2, 3]", {"request"}),
        (b"null", {"request"}),
        (b"[" * 50_000, {"json"}),
        (b'{"op": "ping", "id": 7, "x": ' + b"[" * 5000 + b"]" * 5000 + b"}", {"json"}),
        (nan + b',"id":"nan-1"}', {"request"}),
        (nan.replace(b"NaN", b"Infinity") + b',"id":"inf-1"}', {"request"}),
        (nan.replace(b"NaN", b"1e999") + b',"id":"big-1"}', {"request"}),
        ({"op": "launch_missiles"}, {"op"}),
        ({"op": 7}, {"op"}),
        ({"op": None}, {"op"}),
        ({"op": "ping", "v": 99}, {"version"}),
        ({"op": "ping", "extra": {"a": 1}}, {"request"}),
        ({"op": "sleep", "seconds": -1}, {"request"}),
        ({"op": "sleep", "seconds": "1"}, {"request"}),
        ({"op": "ping", "pad": "x" * (MAX_BYTES + 10)}, {"limit"}),
        (_allowable({"path": "plane.json"}, cc="lots"), {"request"}),
        (_allowable({"path": "plane.json"}, cc=[[1, 2, 3]]), {"request"}),
        (_allowable({"path": "plane.json"}, cc=[[0, 0, 0, 0, 0, 1]] * 1001), {"limit"}),
        (_allowable({"path": "plane.json"}, axis=[0, 0, 0]), {"request"}),
        (_allowable({"path": "plane.json"}, b_range=[10, -10]), {"request"}),
        (_allowable({"path": "plane.json", "x": 1}), {"request"}),
        (_allowable({"path": "plane.json"}, cutter="CUTTER/-5"), {"cutter"}),
        (_allowable({"path": "/etc/passwd"}), {"forbidden"}),
        (_allowable({"path": "/dev/zero"}), {"forbidden"}),
        (_allowable({"path": "/proc/self/environ"}), {"forbidden"}),
        (_allowable({"path": "../../../../../../etc/shadow"}), {"forbidden"}),
        (_allowable({"path": "zero.json"}), {"forbidden"}),
        (_allowable({"path": "passwd.apt"}), {"forbidden"}),
        (_allowable({"path": "sub"}), {"part"}),
        (_allowable({"path": "pipe.json"}), {"part"}),
        (_allowable({"path": "no-such.json"}), {"part"}),
        (_allowable({"path": "secret.txt"}), {"part"}),
        (_allowable({"path": "loop.json"}), {"input"}),
        (_allowable({"path": "plane\x00.json"}), {"request"}),
        (_allowable({"path": "x" * 300}), {"part"}),
        ({"op": "check", "apt_path": "/etc/passwd"}, {"forbidden"}),
        ({"op": "check", "apt_path": "passwd.apt"}, {"forbidden"}),
        ({"op": "check", "apt_path": "secret.txt"}, {"parse", "input", "dialect"}),
        ({"op": "check", "apt_path": "pipe.json"}, {"input"}),
        ({"op": "check", "apt": TINY_APT.format(pprint=""), "machine": "/etc/passwd"},
         {"forbidden"}),
        ({"op": "check", "apt": TINY_APT.format(pprint=""), "machine": "../../../etc/passwd"},
         {"forbidden"}),
        ({"op": "check", "apt": TINY_APT.format(pprint="PPRINT/MACHINE /dev/zero\n")},
         {"forbidden"}),
        ({"op": "check", "apt": TINY_APT.format(pprint=""), "machine": "sub"}, {"machine"}),
        ({"op": "check", "apt": "PARTNO T\nCUTTER/10\nGOTO/1,2,$\n",
          "part": {"path": "plane.json"}}, {"parse"}),
        ({"op": "check", "apt": "X", "options": {"service.debug_ops": True}}, {"request"}),
        ({"op": "check", "apt": "X", "apt_path": "x.apt"}, {"request"}),
        ({"op": "check", "apt": "X", "name": "../../etc/passwd"}, {"request"}),
        ({"op": "ping"}, {"ok"}),
        ({"op": "stats"}, {"ok"}),
        (_allowable({"path": "alias.json"}), {"ok"}),
    ]


BYTE_IDS = {b'"id":"nan-1"': "nan-1", b'"id":"inf-1"': "inf-1", b'"id":"big-1"': "big-1",
            b'"id": 7': 7}


def _send(client: Client, kind: object, n: int) -> tuple[object, dict | PathcheckError]:
    """Send one hostile request; the request as sent (a dict with its id, or bytes) and the
    reply, or the client's own refusal (a request over its size limit is never sent)."""
    message = dict(kind, id=f"h-{n}") if isinstance(kind, dict) else kind
    try:
        return message, client.request(message)
    except PathcheckError as err:
        return message, err


def test_500_hostile_requests_from_6_clients_each_get_one_structured_reply(broker, root):
    pids = sorted(broker.worker_pids())
    kinds = _kinds()
    sent_before = broker.counters.requests

    def run(k: int) -> list[tuple[object, set[str], object]]:
        out = []
        # a client-side limit above the service's: the service's own `limit` reply is tested
        with _client(broker, kind="dealer" if k % 2 else "req",
                     max_message_bytes=4 * MAX_BYTES) as c:
            for i in range(k, 500, 6):
                kind, codes = kinds[i % len(kinds)]
                message, reply = _send(c, kind, i)
                out.append((message, codes, reply))
        return out

    with ThreadPoolExecutor(6) as pool:
        results = [r for client in pool.map(run, range(6)) for r in client]
    assert len(results) == 500
    assert broker.counters.requests - sent_before == 500  # each sent once, none re-sent
    for message, codes, reply in results:
        shown = str(message)[:120]
        assert isinstance(reply, dict), (shown, reply)
        if "ok" in codes:
            assert reply["ok"] is True, (shown, reply)
        else:
            assert reply["ok"] is False and reply["error"]["code"] in codes, (shown, reply)
            assert set(reply["error"]) <= {"code", "message", "line"}
            assert len(reply["error"]["message"]) > 10 and "\n" not in reply["error"]["message"]
            assert "Traceback" not in reply["error"]["message"]
            assert SECRET not in reply["error"]["message"] and "root:x" not in \
                reply["error"]["message"]
        if isinstance(message, dict):
            expected_id = message["id"]
        else:
            expected_id = next((rid for mark, rid in BYTE_IDS.items() if mark in message), None)
        assert reply["id"] == expected_id, (shown, reply)
    assert sorted(broker.worker_pids()) == pids  # no worker died or was replaced
    with _client(broker) as c:
        stats = c.call("stats")
    assert stats["broker"]["queued"] == 0 and stats["broker"]["busy"] == 0


def test_a_file_given_by_path_is_never_echoed(broker, root):
    with _client(broker) as c:
        reply = c.call("check", apt_path="secret.txt")
        outside = c.call("check", apt_path="/etc/passwd")
        zero = c.call("allowable", **{k: v for k, v in _allowable({"path": "zero.json"}).items()
                                      if k != "op"})
    message = reply["error"]["message"]
    assert message.startswith("secret.txt:") and SECRET not in message and "root:x" not in message
    assert outside["error"] == {
        "code": "forbidden",
        "message": "/etc/passwd: outside the service's roots: expected a path under a folder "
                   "given to `pathcheck serve --root` (relative paths are taken from the first "
                   "root)"}
    assert zero["error"]["code"] == "forbidden" and zero["error"]["message"].startswith(
        "zero.json: outside the service's roots")


def test_frame_far_over_the_limit_drops_the_connection_not_the_service(broker):
    """A frame over 4 x max_message_bytes closes that connection without a reply; the client
    refuses to send it at all; the service goes on answering."""
    with _client(broker, max_message_bytes=MAX_BYTES) as c, \
            pytest.raises(PathcheckError, match="the limit is 65536 bytes; not sent"):
        c.call("ping", pad="x" * (MAX_BYTES + 1), id="big")
    sock = zmq.Context.instance().socket(zmq.DEALER)
    sock.connect(broker.address)
    try:
        sock.send_multipart([b"", b'{"op":"ping","pad":"' + b"x" * (5 * MAX_BYTES) + b'"}'])
        assert not sock.poll(1000)
    finally:
        sock.close(linger=0)
    with _client(broker) as c:
        assert c.call("ping")["ok"] is True


# --- faults ---------------------------------------------------------------------------------


def test_a_part_that_took_a_worker_down_is_refused_by_its_content_hash(broker, root):
    """A slow part file whose worker dies mid-request (killed from outside, as a segfault in
    native code would end it), sent three times by a client with retries: one `worker` reply,
    then `crashed` twice without reaching a worker; the same path with other bytes runs."""
    part = root / "crashing.json"
    part.write_text(json.dumps(_surfaces(3, 1000.0)))
    request = _allowable({"path": "crashing.json"})
    fields = {k: v for k, v in request.items() if k != "op"}
    sent_before = broker.counters.requests
    replies = []
    with _client(broker, retries=2) as c, ThreadPoolExecutor(1) as pool:
        pending = pool.submit(c.call, "allowable", id="crash-1", **fields)
        victim = wait_busy(broker)
        time.sleep(0.3)
        os.kill(victim, signal.SIGKILL)
        replies.append(pending.result(30))
        for n in (2, 3):
            t0 = time.perf_counter()
            replies.append(c.call("allowable", id=f"crash-{n}", **fields))
            assert time.perf_counter() - t0 < 2.0  # refused at once, not run
    assert broker.counters.requests - sent_before == 3  # the client re-sent nothing
    assert [r["error"]["code"] for r in replies] == ["worker", "crashed", "crashed"]
    assert [r["id"] for r in replies] == ["crash-1", "crash-2", "crash-3"]
    assert f"took worker {victim} down" in replies[1]["error"]["message"]
    assert victim not in broker.worker_pids()
    part.write_text((root / "plane.json").read_text())  # other bytes: a new request
    with _client(broker) as c:
        assert c.call("allowable", id="crash-4", **fields)["ok"] is True
    broker.wait_started(30, ready_workers=2)


def test_memory_over_the_limit_answers_limit_and_replaces_the_worker(broker):
    pids = set(broker.worker_pids())
    with _client(broker) as c:
        reply = c.call("allowable", id="mem-1", part={"geomdl": _surfaces(40, 1000.0)},
                       cc=[[0, 0, 0, 0, 0, 1]], cutter="CUTTER/10")
    assert reply["ok"] is False and reply["error"]["code"] == "limit" and reply["id"] == "mem-1"
    assert "1000 MiB" in reply["error"]["message"]
    _wait(lambda: len(pids - set(broker.worker_pids())) == 1, what="the worker to be replaced")
    broker.wait_started(30, ready_workers=2)


def test_a_hung_idle_worker_is_detected_by_heartbeat_and_replaced(broker):
    broker.wait_started(30, ready_workers=2)
    victim = broker.worker_pids()[0]
    os.kill(victim, signal.SIGSTOP)
    t0 = time.monotonic()
    try:
        _wait(lambda: victim not in broker.worker_pids(), timeout_s=15, what="heartbeat expiry")
    finally:
        if Path(f"/proc/{victim}").exists():
            os.kill(victim, signal.SIGCONT)
    took = time.monotonic() - t0
    assert 0.5 * 5 * 0.8 < took < 10  # 5 missed beats of 0.5 s, then replaced
    broker.wait_started(30, ready_workers=2)
    with _client(broker) as c:
        assert c.call("sleep", seconds=0)["ok"]


def test_ping_is_answered_by_the_broker_while_every_worker_is_busy(broker):
    broker.wait_started(30, ready_workers=2)
    with _client(broker, kind="dealer") as a, _client(broker, kind="dealer") as b, \
            ThreadPoolExecutor(2) as pool:
        slow = [pool.submit(a.call, "sleep", seconds=4.0), pool.submit(b.call, "sleep",
                                                                       seconds=4.0)]
        _wait(lambda: len(broker.busy_pids()) == 2, what="both workers busy")
        times = []
        with _client(broker) as c:
            for _ in range(15):
                t0 = time.perf_counter()
                reply = c.call("ping")
                times.append(time.perf_counter() - t0)
                assert reply["ok"] and reply["broker"] == os.getpid()
            stats = c.call("stats")
        assert len(broker.busy_pids()) == 2  # still busy: the pings did not wait for them
        assert stats["broker"]["busy"] == 2
        assert all(r.result(20)["ok"] for r in slow)
    assert statistics.median(times) < 0.100, times
    assert max(times) < 0.500, times


def test_an_internal_error_answers_internal_with_the_id_and_logs_the_traceback(
        monkeypatch, caplog):
    """A bug in an op (here injected by the test into the op table) is an `internal` reply
    with the request's id; the traceback goes to the service log; the worker goes on."""
    from checker.service import ops, protocol
    from checker.service.part_cache import PartCache
    from checker.service.recorder import NullRecorder
    from checker.service.worker import handle

    def broken(req, state):
        return {"value": 1 / 0}

    monkeypatch.setitem(ops.OPS, protocol.SleepRequest, broken)
    state = ops.WorkerState(config=_config(), cache=PartCache(1 << 20))
    with caplog.at_level(logging.ERROR, logger="pathcheck.service"):
        reply, meta = handle(b'{"op": "sleep", "seconds": 0, "id": "bug-1"}', state,
                             NullRecorder())
    assert reply["ok"] is False and reply["id"] == "bug-1" and reply["op"] == "sleep"
    assert reply["error"]["code"] == "internal" and meta["exit"] is False
    assert "a bug in pathcheck" in reply["error"]["message"]
    assert "ZeroDivisionError" in reply["error"]["message"]
    assert "Traceback" in caplog.text and "1 / 0" in caplog.text
    after, _ = handle(b'{"op": "ping", "id": 2}', state, NullRecorder())
    assert after["ok"] is True and after["id"] == 2


# --- CURVE ----------------------------------------------------------------------------------


def test_curve_admits_only_clients_with_a_known_key(tmp_path):
    import zmq.auth

    keys = tmp_path / "keys"
    done = subprocess.run([sys.executable, "-m", "checker.cli", "serve", "--new-keys", str(keys)],
                          cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert sorted(Path(p).relative_to(keys).as_posix() for p in done.stdout.split()) == [
        "client.key_secret", "clients/client.key", "server.key", "server.key_secret"]
    assert (keys / "server.key_secret").stat().st_mode & 0o077 == 0
    stranger = tmp_path / "stranger"
    stranger.mkdir()
    zmq.auth.create_certificates(str(stranger), "client")
    (stranger / "server.key").write_bytes((keys / "server.key").read_bytes())

    with running_broker(_config(), bind="tcp://0.0.0.0:*", workers=1, curve_keys=keys) as b:
        address = b.address.replace("0.0.0.0", "127.0.0.1")
        with Client(address, timeout_s=20, curve_keys=keys) as c:
            assert c.call("ping", id="k")["ok"] is True
        called = subprocess.run(
            [sys.executable, "-m", "checker.cli", "call", "ping", "id=7", "--address", address,
             "--curve-keys", str(keys), "--timeout", "20"],
            cwd=REPO, capture_output=True, text=True, timeout=60)
        assert called.returncode == 0 and json.loads(called.stdout)["id"] == 7, called.stderr
        for who in ({"curve_keys": stranger}, {}):
            with Client(address, timeout_s=1.0, retries=0, **who) as c, \
                    pytest.raises(PathcheckError, match="no reply"):
                c.call("ping")


# --- SIGTERM with requests in flight -------------------------------------------------------


def test_sigterm_answers_every_request_exactly_once_with_its_id(tmp_path):
    """`pathcheck serve` with 2 workers: 2 requests running, 4 queued, then SIGTERM, then 3
    more: the running ones finish, every other one gets `unavailable`; every id exactly once;
    exit 0."""
    config = tmp_path / "service.toml"
    config.write_text("[service]\ndebug_ops = true\nrequest_timeout_s = 20.0\n")
    proc = subprocess.Popen(
        [sys.executable, "-m", "checker.cli", "serve", "--bind", "tcp://127.0.0.1:*",
         "--workers", "2", "--config", str(config), "--no-store", "--root", str(tmp_path)],
        cwd=REPO, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True, start_new_session=True)
    lines: list[str] = []
    listening = threading.Event()

    def read() -> None:
        for line in proc.stderr:
            lines.append(line)
            if "listening on" in line:
                listening.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        assert listening.wait(60), "".join(lines)
        address = re.search(r"listening on (\S+)", "".join(lines)).group(1)
        with Client(address, timeout_s=30) as c:  # both workers up
            _wait(lambda: c.call("stats")["broker"]["ready"] == 2, 60, "2 ready workers")
        ctx = zmq.Context.instance()
        socks = [ctx.socket(zmq.DEALER) for _ in range(3)]
        for s in socks:
            s.connect(address)
        sent = []
        for n in range(6):
            sent.append(f"run-{n}")
            socks[n % 3].send_multipart([b"", json.dumps(
                {"op": "sleep", "seconds": 1.5, "id": sent[-1]}).encode()])
        time.sleep(0.5)
        os.kill(proc.pid, signal.SIGTERM)
        time.sleep(0.2)
        for n in range(3):
            sent.append(f"late-{n}")
            socks[n].send_multipart([b"", json.dumps({"op": "ping", "id": sent[-1]}).encode()])
        replies: list[dict] = []
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and len(replies) < len(sent) + 1:
            for s in socks:
                while s.poll(50):
                    replies.append(json.loads(s.recv_multipart()[-1]))
            if proc.poll() is not None and len(replies) >= len(sent):
                time.sleep(0.3)  # anything extra would have arrived by now
                for s in socks:
                    while s.poll(0):
                        replies.append(json.loads(s.recv_multipart()[-1]))
                break
        for s in socks:
            s.close(linger=0)
        assert proc.wait(20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
    assert sorted(r["id"] for r in replies) == sorted(sent)  # each id exactly once
    by_id = {r["id"]: r for r in replies}
    done = [i for i in sent if by_id[i]["ok"]]
    assert len(done) == 2 and all(by_id[i]["slept"] == 1.5 for i in done)
    refused = [by_id[i] for i in sent if not by_id[i]["ok"]]
    assert len(refused) == 7 and all(r["error"]["code"] == "unavailable" for r in refused)
    log = "".join(lines)
    assert "draining: 2 request(s) in flight, 4 queued" in log and "Traceback" not in log


def test_redact_hides_quoted_file_contents_but_keeps_the_given_name():
    from checker.service.roots import redact

    err = PathcheckError("unknown dialect: expected APT-CL, found no such statement; first "
                         "line 'root:x:0:0:root:/root:/bin/bash'", path="jobs/a.txt", line=1)
    shown = redact(err, "jobs/a.txt")
    assert str(shown) == ("jobs/a.txt:1: unknown dialect: expected APT-CL, found no such "
                          "statement; first line '...'")
    assert shown.line == 1 and shown.code == err.code
    kept = redact(PathcheckError("unsupported part file type '.txt', found \"it's\""),
                  "jobs/a.txt")
    assert kept.message == "unsupported part file type '.txt', found '...'"
