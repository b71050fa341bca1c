"""The published service schemas are current (regenerated in memory, compared as parsed JSON),
and the real requests and replies of a running service (a broker and a worker process over a
socket) validate against them with the `jsonschema` library, while malformed requests and
altered replies do not."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import jsonschema
import pytest

from checker.client import Client
from checker.config import default_config
from checker.resources import resource
from checker.service.broker import Broker
from checker.service.schemas import json_schemas

REPO = Path(__file__).resolve().parents[1]
MOULD = REPO / "samples" / "mould" / "mould.json"
SMALL = REPO / "samples" / "compressor" / "compressor_small"


def _published(name: str) -> dict:
    return json.loads(resource("schemas", name).read_text())


def test_published_service_schemas_are_up_to_date():
    generated = json_schemas()
    assert sorted(generated) == ["service-reply.schema.json", "service-request.schema.json"]
    for name, schema in generated.items():
        assert _published(name) == json.loads(json.dumps(schema)), (
            "regenerate with: .venv/bin/python -m checker.service.schemas")


@pytest.fixture(scope="module")
def validators() -> tuple[jsonschema.Draft202012Validator, jsonschema.Draft202012Validator]:
    request, reply = (_published(f"service-{k}.schema.json") for k in ("request", "reply"))
    for schema in (request, reply):
        jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(request), jsonschema.Draft202012Validator(reply)


@pytest.fixture(scope="module")
def exchanges(tmp_path_factory) -> list[tuple[dict, dict]]:
    """(request, reply) of every op, successes and failures, from a real service."""
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate

    surface = load_part(MOULD).surfaces[0]
    (u0, u1), (v0, v1) = surface.domain
    on = evaluate(surface, [u0 + 0.3 * (u1 - u0), u0 + 0.6 * (u1 - u0)],
                  [v0 + 0.6 * (v1 - v0), v0 + 0.3 * (v1 - v0)])
    cc = [[*p, *n] for p, n in zip(on.points.tolist(), on.normals.tolist(), strict=True)]
    lines = SMALL.with_suffix(".apt").read_text().splitlines()[:16]  # approach + 5 feed moves
    tiny = "\n".join([*lines, "END", "FINI", ""])
    base = default_config()
    config = base.model_copy(update={"service": base.service.model_copy(
        update={"debug_ops": True, "request_timeout_s": 600.0})})
    broker = Broker(config, bind="tcp://127.0.0.1:*", workers=1)
    thread = threading.Thread(target=broker.run, daemon=True)
    thread.start()
    requests = [
        {"op": "ping", "id": 1},
        {"op": "sleep", "seconds": 0, "id": "s"},
        {"op": "stats", "v": 1},
        {"op": "allowable", "id": 2, "part": {"path": str(MOULD)}, "cutter": "CUTTER/12,3",
         "cc": cc},
        {"op": "allowable", "id": 3, "part": {"path": str(MOULD)}, "cutter": "CUTTER/12,3",
         "cc": cc[:1], "b_range": [-10.0, 10.0]},
        {"op": "check", "id": 4, "apt": tiny, "name": "tiny",
         "part": {"path": str(SMALL.with_suffix(".json"))}, "post": True},
        {"op": "check", "id": 5, "apt": tiny.replace("GOTO/", "GOTO/ABC,", 1),
         "part": {"path": str(SMALL.with_suffix(".json"))}},
    ]
    malformed = [{"op": "nope", "id": 6}, {"op": "ping", "v": 2}, {"op": "ping", "extra": 1},
                 {"op": "allowable", "part": {"path": "x"}, "cc": [], "cutter": "CUTTER/6"},
                 {"op": "check", "apt": "X", "apt_path": "y.apt"}, {"id": 7}]
    try:
        broker.wait_started(120, ready_workers=1)
        with Client(broker.address, timeout_s=600.0) as client:
            out = [(r, client.request(r)) for r in requests + malformed]
    finally:
        broker.stop()
        thread.join(15)
    return out


def test_real_requests_and_replies_validate_against_the_schemas(exchanges, validators):
    request_schema, reply_schema = validators
    ok_ops = []
    for request, reply in exchanges:
        reply_schema.validate(reply)
        if reply["ok"]:
            request_schema.validate(request)
            ok_ops.append(reply["op"])
    assert ok_ops == ["ping", "sleep", "stats", "allowable", "allowable", "check"]
    check = exchanges[5][1]
    assert check["gcode"].startswith("%") and check["results"]["job"]["path"] == "tiny.apt"
    assert "b_best" in exchanges[4][1]["points"][0]
    assert exchanges[6][1]["error"]["code"] == "parse" and exchanges[6][1]["error"]["line"] > 0


def test_malformed_requests_fail_the_schema_as_they_fail_the_service(exchanges, validators):
    request_schema, reply_schema = validators
    refused = [(q, r) for q, r in exchanges if not r["ok"] and r["error"]["code"] != "parse"]
    assert len(refused) == 6
    for request, reply in refused:
        assert reply["error"]["code"] in ("op", "version", "request")
        assert not request_schema.is_valid(request), request


def test_altered_replies_fail_the_schema(exchanges, validators):
    _, reply_schema = validators
    ping, stats, check = exchanges[0][1], exchanges[2][1], exchanges[5][1]
    for altered in ({**ping, "pong": False}, {**ping, "op": "pong"}, {**ping, "extra": 1},
                    {**stats, "broker": {**stats["broker"], "pids": "1"}},
                    {**check, "results": {**check["results"], "summary": None}},
                    {"ok": False, "v": 1, "id": None, "op": None, "error": {"code": "x"}}):
        assert not reply_schema.is_valid(altered)
