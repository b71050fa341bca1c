"""`pathcheck serve` as a real process on 127.0.0.1: `pathcheck call` against it, every request
recorded in the results store, and SIGTERM draining the request in flight and exiting 0."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from checker.client import Client
from checker.errors import PathcheckError
from checker.store import ResultsStore

REPO = Path(__file__).resolve().parents[1]


class Server:
    """A `pathcheck serve` subprocess; its stderr lines are collected by a thread."""

    def __init__(self, tmp: Path) -> None:
        config = tmp / "service.toml"
        config.write_text("[service]\ndebug_ops = true\nrequest_timeout_s = 20.0\n"
                          "max_message_bytes = 65536\n")
        self.store = tmp / "store.sqlite"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "checker.cli", "serve", "--bind", "tcp://127.0.0.1:*",
             "--workers", "2", "--config", str(config), "--store", str(self.store)],
            cwd=REPO, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE, text=True, start_new_session=True,
        )
        self.lines: list[str] = []
        self.listening = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()
        if not self.listening.wait(60):
            self.proc.kill()
            pytest.fail("serve did not start:\n" + "".join(self.lines))
        self.address = re.search(r"listening on (\S+)", "".join(self.lines)).group(1)

    def _read(self) -> None:
        for line in self.proc.stderr:
            self.lines.append(line)
            if "listening on" in line:
                self.listening.set()

    def call(self, *args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "checker.cli", "call", *args, "--address", self.address,
             "--timeout", "20"],
            cwd=REPO, capture_output=True, text=True, timeout=60,
        )


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    srv = Server(tmp_path_factory.mktemp("serve"))
    yield srv
    if srv.proc.poll() is None:
        srv.proc.kill()
        srv.proc.wait(10)


def test_call_ping_prints_the_reply(server):
    done = server.call("ping", "id=7")
    assert done.returncode == 0, done.stderr
    reply = json.loads(done.stdout)
    assert reply["ok"] is True and reply["pong"] is True and reply["id"] == 7


def test_call_error_reply_is_one_line_and_exit_2(server):
    done = server.call("allowable", "part.path=no/such/part.json", "cutter=CUTTER/10",
                       "cc=[[0,0,0,0,0,1]]")
    assert done.returncode == 2
    assert done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pathcheck: no/such/part.json: ")
    assert "expected a part file, found nothing" in lines[0]
    outside = server.call("allowable", "part.path=/etc/passwd", "cutter=CUTTER/10",
                          "cc=[[0,0,0,0,0,1]]")  # the default root is the working directory
    assert outside.returncode == 2
    assert outside.stderr.strip() == (
        "pathcheck: /etc/passwd: outside the service's roots: expected a path under a folder "
        "given to `pathcheck serve --root` (relative paths are taken from the first root)")


def test_call_bad_field_syntax_is_a_usage_error(server):
    done = server.call("ping", "novalue")
    assert done.returncode == 2 and "expected FIELD=VALUE" in done.stderr


def test_one_log_line_per_request_and_every_request_recorded(server):
    before = sum("request client=" in line for line in server.lines)
    t0 = time.time()
    with Client(server.address, timeout_s=20) as c:
        for _ in range(5):
            assert c.call("ping")["ok"]
        assert not c.request(b"{oops")["ok"]
        assert c.call("ping", pad="x" * 70_000)["error"]["code"] == "limit"  # broker answers
    deadline = time.monotonic() + 10
    while sum("request client=" in line for line in server.lines) < before + 7:
        assert time.monotonic() < deadline, "".join(server.lines[-10:])
        time.sleep(0.05)
    assert any("op=? id=null ok=false code=json" in line for line in server.lines)
    while True:  # the broker records on a thread of its own: the rows follow the replies
        with ResultsStore(server.store) as store:
            rows = store.requests(since=t0)
        if len(rows) >= 7 or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert len(rows) == 7
    assert [r[1] for r in rows].count("ping") == 5
    assert any(r[1] == "?" and r[2] == 0 and "not valid JSON" in r[4] for r in rows)
    assert any(r[2] == 0 and "the limit is 65536 bytes" in r[4] for r in rows)


def test_call_reads_the_request_from_stdin_and_writes_out(server, tmp_path):
    from click.testing import CliRunner

    from checker.commands.call import call

    out = tmp_path / "reply.json"
    result = CliRunner().invoke(
        call, ["stats", "--address", server.address, "--request", "-", "--out", str(out),
               "--dealer", "--timeout", "20", "--retries", "0"], input='{"id": "from-stdin"}')
    assert result.exit_code == 0, result.output
    reply = json.loads(out.read_text())
    assert reply["id"] == "from-stdin" and reply["broker"]["workers"] == 2


def test_call_cc_csv_and_nested_fields(tmp_path):
    from checker.cc_csv import cc_rows
    from checker.commands.call import _field, _set

    csv = tmp_path / "cc.csv"
    csv.write_text("x,y,z,nx,ny,nz\n1,2,3,0,0,1\n4.5,5,6,0,1,0\n")
    assert cc_rows(csv) == [[1, 2, 3, 0, 0, 1], [4.5, 5, 6, 0, 1, 0]]
    csv.write_text("x,y,z\n1,2,3\n")
    with pytest.raises(PathcheckError, match="expected the header x,y,z,nx,ny,nz"):
        cc_rows(csv)
    message: dict = {}
    for item in ("part.path=a.json", "cc=[[0,0,0,0,0,1]]", "cutter=CUTTER/10,2", "post=true"):
        _set(message, *_field(item))
    assert message == {"part": {"path": "a.json"}, "cc": [[0, 0, 0, 0, 0, 1]],
                       "cutter": "CUTTER/10,2", "post": True}


def test_sigterm_drains_the_request_in_flight_and_exits_0(server):
    """SIGTERM to the whole process group (as systemd and shells send it): the broker drains,
    the busy worker finishes its request first, the service exits 0 with no worker left."""
    with Client(server.address, timeout_s=20) as c:
        pids = c.call("stats")["broker"]["pids"]
    assert len(pids) == 2
    with Client(server.address, timeout_s=20, kind="dealer") as slow, \
            Client(server.address, timeout_s=20, kind="dealer", retries=0) as late:
        sock = slow._socket()
        sock.send_multipart([b"", json.dumps({"op": "sleep", "seconds": 1.5, "id": 1}).encode()])
        time.sleep(0.5)
        os.killpg(server.proc.pid, signal.SIGTERM)
        time.sleep(0.2)
        rejected = late.call("ping")
        assert sock.poll(20_000), "the request in flight was not answered"
        drained = json.loads(sock.recv_multipart()[-1])
    assert drained["ok"] is True and drained["slept"] == 1.5
    assert rejected["ok"] is False and rejected["error"]["code"] == "unavailable"
    assert server.proc.wait(20) == 0
    for pid in pids:
        assert not Path(f"/proc/{pid}").exists(), f"worker {pid} outlived the server"
    log = "".join(server.lines)
    assert "draining: 1 request(s) in flight" in log and "stopped" in log
    assert "Traceback" not in log


def test_serve_bad_bind_is_a_clean_error():
    done = subprocess.run(
        [sys.executable, "-m", "checker.cli", "serve", "--bind", "nonsense://x", "--no-store"],
        cwd=REPO, capture_output=True, text=True, timeout=60, env=dict(os.environ),
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1].startswith("pathcheck: cannot bind nonsense://x")


def test_bind_beyond_loopback_needs_curve_or_insecure():
    from checker.service.broker import check_bind

    for local in ("tcp://127.0.0.1:5555", "tcp://127.0.0.2:*", "tcp://[::1]:5555",
                  "tcp://localhost:5555", "ipc:///tmp/pc", "inproc://x", "ws://127.0.0.1:80/p"):
        check_bind(local, curve=False, insecure=False)
    for exposed in ("tcp://0.0.0.0:5555", "tcp://*:5555", "tcp://eth0:5555",
                    "tcp://192.168.1.4:5555", "tcp://[::]:5555", "udp://127.0.0.1:5555"):
        with pytest.raises(PathcheckError, match="may be reachable from other machines"):
            check_bind(exposed, curve=False, insecure=False)
        check_bind(exposed, curve=True, insecure=False)
        check_bind(exposed, curve=False, insecure=True)
    done = subprocess.run(
        [sys.executable, "-m", "checker.cli", "serve", "--bind", "tcp://0.0.0.0:*", "--no-store"],
        cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "pathcheck: tcp://0.0.0.0:* may be reachable from other machines: give --curve-keys DIR "
        "(keys from `pathcheck serve --new-keys DIR`) or --insecure, or bind "
        "tcp://127.0.0.1:PORT")
