"""Protocol validation, reply encoding, the part cache's LRU and the request recorder, without
sockets."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from checker.errors import PathcheckError
from checker.service import protocol as p
from checker.service.part_cache import CachedPart, PartCache, deep_nbytes, file_key, json_key
from checker.service.recorder import NullRecorder, StoreRecorder, open_recorder
from checker.store import ResultsStore


def parse(obj, **kw) -> p.Request:
    raw = obj if isinstance(obj, bytes) else json.dumps(obj).encode()
    kw.setdefault("max_bytes", 10_000)
    kw.setdefault("max_points", 10)
    return p.parse_request(raw, **kw)


def error(obj, **kw) -> PathcheckError:
    with pytest.raises(PathcheckError) as exc:
        parse(obj, **kw)
    return exc.value


def test_valid_requests_parse_to_their_models():
    req = parse({"op": "allowable", "id": "r1", "part": {"path": "a.json"},
                 "cc": [[0, 0, 1, 0, 0, 1]], "cutter": "CUTTER/10", "b_range": [-30, 30]})
    assert isinstance(req, p.AllowableRequest) and req.id == "r1"
    assert req.part == p.PartPath(path="a.json") and req.axis == (0.0, 0.0, 1.0)
    assert req.cc == [(0.0, 0.0, 1.0, 0.0, 0.0, 1.0)] and req.b_range == (-30.0, 30.0)
    inline = parse({"op": "allowable", "part": {"geomdl": {"shape": {}}},
                    "cc": [[0, 0, 1, 0, 0, 1]], "cutter": "CUTTER/10"})
    assert isinstance(inline.part, p.PartInline)
    check = parse({"op": "check", "apt": "PARTNO X", "post": True, "options": {"tol": 0.01}})
    assert isinstance(check, p.CheckRequest) and check.post and check.options == {"tol": 0.01}
    assert isinstance(parse({"op": "ping", "v": 1}), p.PingRequest)
    assert isinstance(parse({"op": "stats"}), p.StatsRequest)


@pytest.mark.parametrize(
    ("raw", "code", "text"),
    [
        (b"{", "json", "not valid JSON"),
        (b"\xff", "json", "not valid JSON"),
        (b"42", "request", "must be a JSON object, found int"),
        (b"{}", "op", "no 'op' field"),
        ({"op": "fly"}, "op", "unknown op 'fly'; expected one of ping, stats, allowable, check"),
        ({"op": "sleep", "seconds": 1}, "op", "unknown op 'sleep'"),
        ({"op": "ping", "v": 3}, "version", "protocol version 3 is not supported"),
        ({"op": "ping", "id": [1]}, "request", "field 'id'"),
        ({"op": "ping", "bogus": 1}, "request", "field 'bogus': Extra inputs are not permitted"),
        ({"op": "allowable", "part": {"path": "a"}, "cc": [[0, 0, "1", 0, 0, 1]], "cutter": "C"},
         "request", "field 'cc.0.2': Input should be a valid number, found \"1\""),
        ({"op": "allowable", "part": {"path": "a"}, "cc": [[0, 0, 1, 0, 0]], "cutter": "C"},
         "request", "field 'cc.0': too few items (item 5 is missing)"),
        ({"op": "allowable", "part": {"path": "a"}, "cc": [[0, 0, 1, 0, 0, 1]], "cutter": "C",
          "axis": [0, 0, 0]}, "request", "axis must be a non-zero vector"),
        ({"op": "allowable", "part": {"path": "a"}, "cc": [[0, 0, 1, 0, 0, 1]], "cutter": "C",
          "b_range": [10, -10]}, "request", "lo < hi"),
        ({"op": "allowable", "part": {"path": "a"}, "cc": [[0, 0, 1, 0, 0, 1]] * 11,
          "cutter": "C"}, "limit", "11 points, the limit is 10"),
        ({"op": "check"}, "request", "exactly one of 'apt'"),
        ({"op": "check", "apt": "X", "apt_path": "y"}, "request", "exactly one of 'apt'"),
        ({"op": "ping", "pad": "x" * 10_000}, "limit", "the limit is 10000 bytes"),
    ],
)
def test_malformed_requests_name_the_field_and_what_was_found(raw, code, text):
    err = error(raw)
    assert err.code == code
    assert text in str(err)


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity", "1e400"])
def test_non_finite_coordinates_are_rejected(literal):
    raw = b'{"op":"allowable","part":{"path":"a"},"cc":[[0,0,X,0,0,1]],"cutter":"C"}'
    raw = raw.replace(b"X", literal.encode())
    err = error(raw)
    assert err.code == "request" and "field 'cc.0.2': Input should be a finite number" in str(err)


def test_debug_op_only_when_enabled():
    assert isinstance(parse({"op": "sleep", "seconds": 0.5}, debug_ops=True), p.SleepRequest)


def test_replies_and_peek():
    err = PathcheckError("expected X, found Y", path="job.apt", line=12, code="parse")
    reply = p.error_reply(err, request_id="a", op="check")
    assert reply == {"ok": False, "v": 1, "id": "a", "op": "check",
                     "error": {"code": "parse", "message": "job.apt:12: expected X, found Y",
                               "line": 12}}
    assert json.loads(p.encode(p.ok_reply({"x": float("nan"), "y": [float("inf"), 1.5]},
                                          op="ping"))) == {
        "ok": True, "v": 1, "id": None, "op": "ping", "x": None, "y": [None, 1.5]}
    assert p.peek(b'{"id": 5, "op": "check", "junk": ') == (5, None)  # scanned: cut short
    assert p.peek(b'{"op": "check", "junk": ') == (None, None)
    deep = b'{"op": "ping", "id": "d", "x": ' + b"[" * 5000 + b"]" * 5000 + b"}"
    assert p.peek(deep) == ("d", None)  # too deep to parse: scanned
    big = b'{"op": "check", "apt": "' + b"x" * (p.PEEK_BYTES + 1) + b'", "id": 12}'
    assert p.peek(big) == (12, None)  # too large to parse in the broker: scanned
    assert p.peek(b'{"op": "check", "apt": "' + b"x" * p.PEEK_BYTES + b'"}') == (None, None)
    assert p.peek(b'{"id": 5, "op": "check"}') == (5, "check")
    assert p.peek(b'{"id": true, "op": 3}') == (None, None)


def _entry(nbytes: int) -> CachedPart:
    return CachedPart(part=None, test_points=None, nbytes=nbytes, load_s=0.0, sample_s=0.0)


def test_part_cache_is_lru_bounded_by_bytes():
    cache = PartCache(max_bytes=100)
    built: list[str] = []

    def build(key: str, size: int):
        def make() -> CachedPart:
            built.append(key)
            return _entry(size)
        return make

    assert cache.get("a", build("a", 40)) == (_entry(40), False)
    assert cache.get("b", build("b", 40))[1] is False
    assert cache.get("a", build("a", 40))[1] is True  # a is now the most recent
    cache.get("c", build("c", 40))  # 120 > 100: b (least recent) goes
    assert list(cache.entries) == ["a", "c"] and cache.evictions == 1
    cache.get("huge", build("huge", 500))  # larger than the bound: answered, not kept
    assert list(cache.entries) == ["a", "c"]
    assert built == ["a", "b", "c", "huge"]
    assert cache.stats() == {"entries": 2, "bytes": 80, "max_bytes": 100, "hits": 1,
                             "misses": 4, "evictions": 1}
    cache.get("full", build("full", 100))  # exactly the bound: both others go
    assert list(cache.entries) == ["full"] and (cache.nbytes, cache.evictions) == (100, 3)


def test_content_keys(tmp_path):
    f1, f2 = tmp_path / "a.json", tmp_path / "b.json"
    f1.write_bytes(b"same")
    f2.write_bytes(b"same")
    assert file_key(f1) == file_key(f2) != file_key(f1, salt="sag=0.1")
    assert json_key({"a": 1, "b": 2}) == json_key({"b": 2, "a": 1}) != json_key({"a": 2})
    with pytest.raises(PathcheckError) as exc:
        file_key(tmp_path / "missing.json")
    assert exc.value.code == "part" and "missing.json" in str(exc.value)


def test_deep_nbytes_counts_arrays_once():
    from checker.geometry.nearest import PointTree

    a = np.zeros((100, 3))
    obj = {"x": a, "y": [a, np.zeros(10, dtype=np.int32)], "tree": PointTree(np.ones((50, 3)))}
    assert deep_nbytes(obj) == 2400 + 40 + 1200  # the tree: its points


def test_store_recorder_writes_request_rows(tmp_path):
    recorder = open_recorder(tmp_path / "s.sqlite")
    assert isinstance(recorder, StoreRecorder)
    recorder.record("ping", {"ok": True}, 0.001)
    recorder.record("?", {"ok": False, "error": {"code": "json", "message": "bad"}}, 0.002)
    with ResultsStore(tmp_path / "s.sqlite") as store:
        rows = store.requests()
    assert [(r[1], r[2], r[4]) for r in rows] == [("ping", 1, None), ("?", 0, "bad")]
    assert isinstance(open_recorder(None), NullRecorder)


def test_store_recorder_never_raises():
    class Broken:
        def record_request(self, *a, **k):
            raise RuntimeError("disk full")

    StoreRecorder(Broken()).record("ping", {"ok": True}, 0.0)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=6) | st.dictionaries(st.text(max_size=8), inner,
                                                                 max_size=6),
    max_leaves=8,
)


@settings(max_examples=300, deadline=None)
@given(raw=st.binary(max_size=300))
def test_random_bytes_raise_only_pathcheck_errors(raw):
    try:
        parse(raw)
    except PathcheckError as err:
        assert err.code in {"json", "request", "op", "version", "limit"}


@settings(max_examples=100, deadline=None)
@given(op=st.sampled_from([*p.OPS, "sleep", "other"]),
       fields=st.dictionaries(st.sampled_from(["id", "v", "part", "cc", "cutter", "axis",
                                               "b_range", "apt", "apt_path", "post", "x"]),
                              json_values, max_size=4))
def test_random_requests_parse_or_raise_a_pathcheck_error(op, fields):
    raw = json.dumps({"op": op, **fields}).encode()
    try:
        request = parse(raw)
    except PathcheckError as err:
        assert str(err) and err.code in {"json", "request", "op", "version", "limit"}
    else:
        assert request.op == op


def test_background_recorder_prunes_to_keep_days_then_records(tmp_path):
    """The broker's recorder applies the retention on its own thread before recording: with
    keep_days 0 what was stored before it started goes, what it records after stays."""
    from checker.service.recorder import BackgroundRecorder

    path = tmp_path / "store.sqlite"
    with ResultsStore(path) as store:
        store.record_request("ping", True, 0.01)
        store.record_request("check", False, 0.02, error="old")
    recorder = BackgroundRecorder(path, keep_days=0.0)
    recorder.record("stats", {"ok": True}, 0.03)
    recorder.close()
    with ResultsStore(path) as store:
        assert [(r[1], r[2]) for r in store.requests()] == [("stats", 1)]
    kept = BackgroundRecorder(path)  # no keep_days: nothing pruned
    kept.record("ping", {"ok": True}, 0.01)
    kept.close()
    with ResultsStore(path) as store:
        assert [r[1] for r in store.requests()] == ["stats", "ping"]
