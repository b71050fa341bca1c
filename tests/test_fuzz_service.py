"""Seeded fuzzing of the service (issue #18): valid requests (ping, stats, allowable by path
and inline, check inline and by path) damaged at the byte level (flips, inserted, deleted and
duplicated bytes, truncation) or in their JSON (a value replaced by NaN, 1e308, a huge integer,
a wrong type, a deep nesting, a hostile path; a key dropped or added; the op swapped), sent by
3 concurrent clients to a real broker with 2 worker processes under a 2 GB memory limit.

Every request must get exactly one reply: `ok`, or an error with a known code, a one-line
message without a traceback or the contents of a file, and the request's id whenever the
request is a JSON object with a valid `id`; no `internal` error, no worker lost (a `limit`
reply retires its worker, nothing else may), every reply within 60 s, no worker over 2 GB.

`make test` runs a small sample; PATHCHECK_FUZZ=nightly runs 500 (PATHCHECK_FUZZ=N: N). Case
i is the same on every run (seeded by i; PATHCHECK_SEED=S: a fresh set, seeded by S too); a
failure names the case and its mutation."""

from __future__ import annotations

import copy
import json
import os
import random
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from brokers import running_broker, service_config

from checker.client import Client
from checker.errors import PathcheckError

REPO = Path(__file__).resolve().parents[1]
MAX_BYTES = 256 * 1024
MEMORY_BYTES = 2 * 1024**3
SECRET = "s3cret-token-0815"
_QUICK, _NIGHTLY = 60, 500
KNOWN = {"json", "request", "op", "version", "limit", "part", "cutter", "parse", "input",
         "dialect", "machine", "forbidden", "crashed", "timeout", "busy", "unavailable", "post",
         "geometry", "units", "config"}
TINY = REPO / "samples" / "compressor" / "compressor_small"
HOSTILE_PATHS = ["/etc/passwd", "/dev/zero", "../../../../etc/shadow", "secret.txt", "sub",
                 "/proc/self/mem", "plane.json/..", "", "~/x", "\x00"]
HOSTILE_VALUES = [None, True, -1, 0, 10**30, 1e308, -1e308, 1e-300, "", "x" * 5000, [], {},
                  json.loads("[" * 400 + "]" * 400), {"a": {"b": {"c": None}}}]


def _cases() -> int:
    mode = os.environ.get("PATHCHECK_FUZZ", "")
    if mode == "nightly":
        return _NIGHTLY
    return int(mode) if mode.isdigit() else _QUICK


def _plane(size: float = 50.0) -> dict:
    xs = [-size + 2 * size * k / 3 for k in range(4)]
    knots = [0, 0, 0, 0, 1, 1, 1, 1]
    return {"shape": {"type": "surface", "count": 1, "data": [{
        "type": "spline", "rational": False, "degree_u": 3, "degree_v": 3,
        "knotvector_u": knots, "knotvector_v": knots, "size_u": 4, "size_v": 4,
        "control_points": {"points": [[x, y, 0.0] for x in xs for y in xs]}}]}}


def _tiny_apt() -> str:
    """The approach and first 5 feed moves of the small compressor job."""
    lines = TINY.with_suffix(".apt").read_text().splitlines()[:16]
    return "\n".join([*lines, "END", "FINI", ""])


def _templates() -> list[dict]:
    cc = [[0.0, 0.0, 0.0, 0.0, 0.0, 1.0], [10.0, -5.0, 0.0, 0.0, 0.0, 1.0]]
    return [
        {"op": "ping"},
        {"op": "stats"},
        {"op": "sleep", "seconds": 0.0},
        {"op": "allowable", "part": {"path": "plane.json"}, "cc": cc, "cutter": "CUTTER/10"},
        {"op": "allowable", "part": {"geomdl": _plane()}, "cc": cc, "cutter": "CUTTER/12,3",
         "axis": [0.0, 0.0, 1.0]},
        {"op": "check", "apt": _tiny_apt(), "name": "tiny", "part": {"path": "small.json"},
         "options": {"check.tolerance": 0.002}},
        {"op": "check", "apt_path": "tiny.apt", "machine": "fanuc-hmc"},
    ]


# --- mutations: (rng, request) -> (bytes, description) ------------------------------------


def _paths(obj: object, prefix: tuple = ()) -> list[tuple]:
    """Every key/index path in a JSON value (lists: their first 3 items)."""
    out = []
    items = obj.items() if isinstance(obj, dict) else \
        enumerate(obj[:3]) if isinstance(obj, list) else []
    for key, value in items:
        out.append((*prefix, key))
        out.extend(_paths(value, (*prefix, key)))
    return out


def _set(obj: object, path: tuple, value: object) -> None:
    for key in path[:-1]:
        obj = obj[key]
    obj[path[-1]] = value


def _json_mutation(rng: random.Random, request: dict) -> tuple[bytes, str]:
    out = copy.deepcopy(request)
    paths = [p for p in _paths(out) if p != ("id",)]
    choice = rng.randrange(5)
    if choice == 0 and paths:
        path = rng.choice(paths)
        value = rng.choice(HOSTILE_VALUES)
        _set(out, path, value)
        what = f"{'.'.join(map(str, path))} = {json.dumps(value)[:40]}"
    elif choice == 1 and paths:
        path = rng.choice([p for p in paths if isinstance(p[-1], str)] or paths)
        parent = out
        for key in path[:-1]:
            parent = parent[key]
        del parent[path[-1]]
        what = f"{'.'.join(map(str, path))} dropped"
    elif choice == 2:
        key = rng.choice(["path", "part", "extra", "op", "apt_path", "machine", "cc"])
        out[key] = rng.choice(HOSTILE_PATHS + HOSTILE_VALUES)
        what = f"{key} = {json.dumps(out[key])[:40]}"
    elif choice == 3:
        out["op"] = rng.choice(["ping", "stats", "allowable", "check", "sleep", "Ping", "x"])
        what = f"op -> {out['op']}"
    else:
        for path in paths:
            if path[-1] == "path" or path[-1] in ("apt_path", "machine"):
                _set(out, path, rng.choice(HOSTILE_PATHS))
        what = "paths -> hostile"
    raw = json.dumps(out).encode()
    if rng.random() < 0.2:  # numbers JSON has no word for
        token = rng.choice([b"NaN", b"Infinity", b"-Infinity", b"1e999"])
        raw = raw.replace(b"0.0", token, 1)
        what += f", 0.0 -> {token.decode()}"
    return raw, what


def _byte_mutation(rng: random.Random, request: dict) -> tuple[bytes, str]:
    raw = json.dumps(request).encode()
    i = rng.randrange(len(raw))
    kind = rng.randrange(5)
    if kind == 0:
        out = bytearray(raw)
        out[i] ^= 1 << rng.randrange(8)
        return bytes(out), f"bit flipped at {i}"
    if kind == 1:
        return raw[:i] + bytes([rng.randrange(256)]) + raw[i:], f"byte inserted at {i}"
    if kind == 2:
        n = rng.randrange(1, 20)
        return raw[:i] + raw[i + n:], f"{n} bytes deleted at {i}"
    if kind == 3:
        n = rng.randrange(1, 200)
        return raw[:i] + raw[i:i + n] * rng.randrange(2, 50) + raw[i + n:], f"span at {i} repeated"
    return raw[:i], f"cut at {i}"


def _case(i: int) -> tuple[bytes, str, object]:
    """Case i: (request bytes, description, the id the reply must carry or `None` when the
    request does not parse to an object with a valid id)."""
    rng = random.Random(f"{os.environ.get('PATHCHECK_SEED', '')}service-{i}")
    templates = _templates()
    t = rng.randrange(len(templates))
    request = dict(templates[t], id=rng.choice([f"fz-{i}", i, f"fz-{i}-" + "é" * 3]))
    mutate = _json_mutation if rng.random() < 0.6 else _byte_mutation
    raw, what = mutate(rng, request)
    try:
        data = json.loads(raw)
    except (ValueError, RecursionError):
        data = None
    rid = data.get("id") if isinstance(data, dict) else None
    valid = isinstance(rid, int | str) and not isinstance(rid, bool)
    return raw, f"case {i}: template {t} ({templates[t]['op']}), {what}", rid if valid else None


@pytest.fixture(scope="module")
def broker(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzzroot")
    (root / "plane.json").write_text(json.dumps(_plane()))
    (root / "small.json").write_text(TINY.with_suffix(".json").read_text())
    (root / "tiny.apt").write_text(_tiny_apt())
    (root / "secret.txt").write_text(f"{SECRET}\n")
    (root / "sub").mkdir()
    config = service_config(debug_ops=True, max_message_bytes=MAX_BYTES, request_timeout_s=60.0,
                            max_points=1000, worker_memory_bytes=MEMORY_BYTES)
    with running_broker(config, roots=[root]) as b:
        yield b


def _problem(raw: bytes, want_id: object, reply: object, took: float) -> str | None:
    if isinstance(reply, PathcheckError):
        return f"no reply: {reply}"
    if took > 60:
        return f"took {took:.0f} s"
    if reply.get("id") != want_id and want_id is not None:
        return f"id {reply.get('id')!r}, expected {want_id!r}"
    if reply["ok"]:
        return None
    error = reply["error"]
    message = error["message"]
    if error["code"] not in KNOWN:
        return f"code {error['code']}: {message}"
    if "\n" in message or "Traceback" in message or SECRET in message:
        return f"message: {message[:300]}"
    return None


def test_fuzzed_requests_each_get_one_structured_reply(broker):
    n = _cases()
    cases = [_case(i) for i in range(n)]
    pids = set(broker.worker_pids())
    sent_before = broker.counters.requests

    def run(k: int) -> list[tuple[str, str | None, dict | None]]:
        out = []
        with Client(broker.address, timeout_s=90, retries=0, kind="dealer" if k else "req",
                    max_message_bytes=4 * MAX_BYTES) as c:
            for raw, what, want_id in cases[k::3]:
                t0 = time.perf_counter()
                try:
                    reply = c.request(raw)
                except PathcheckError as err:
                    reply = err
                problem = _problem(raw, want_id, reply, time.perf_counter() - t0)
                out.append((what, problem, reply if isinstance(reply, dict) else None))
        return out

    with ThreadPoolExecutor(3) as pool:
        results = [r for client in pool.map(run, range(3)) for r in client]
    problems = [f"{what}: {problem}" for what, problem, _ in results if problem]
    assert not problems, "\n".join(problems[:20])
    assert len(results) == n and broker.counters.requests - sent_before == n
    retired = sum(1 for _, _, r in results if r and not r["ok"]
                  and r["error"]["code"] == "limit" and "memory" in r["error"]["message"])
    assert len(pids - set(broker.worker_pids())) == retired  # no worker lost otherwise
    assert any(r and r["ok"] for _, _, r in results)  # the mutations leave some valid ones
    for pid in broker.worker_pids():
        status = Path(f"/proc/{pid}/status").read_text()
        hwm_kb = int(next(line.split()[1] for line in status.splitlines()
                          if line.startswith("VmHWM")))
        assert hwm_kb * 1024 < MEMORY_BYTES
