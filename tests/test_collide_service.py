"""The machine check through the service's `check`, over a real ZeroMQ broker and a worker
process whose root is one folder holding the descent job of tests/collide_machines.py and its
machine: the reply's `machine` section (valid against the published results schema) holds the
nose on the block at the closed form's Z, and `post` returns the program with the collision
named; a machine without components is a `request` error naming the field, a clearance out of
range fails validation, and a missing collision library is an `extra` error."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest
from brokers import client_of_root
from collide_machines import descent_job, machine_file, the_descent_finding
from requires import require_extra

from checker.client import Client
from checker.config import default_config
from checker.resources import resource

require_extra("coal", "machine")


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("machine-root")
    descent_job(folder)
    machine_file(folder, "linuxcnc-head-head-ac", "").rename(folder / "bare.toml")
    return folder


@pytest.fixture(scope="module")
def client(root):
    with client_of_root(root) as c:
        yield c


def _check(client: Client, root: Path, machine: str = "head.toml", **fields) -> dict:
    return client.call("check", apt_path=str(root / "descent.apt"),
                       machine=str(root / machine), **fields)


def test_the_check_reply_holds_the_machine_finding(client, root):
    schema = json.loads(resource("schemas", "results.schema.json").read_text())
    reply = _check(client, root, machine_clearance=0.5, post=True, on_findings="comment")
    assert reply["ok"], reply
    jsonschema.validate(reply["results"], schema)
    m = reply["results"]["machine"]
    assert m["clearance"] == 0.5
    the_descent_finding(m)
    assert reply["results"]["summary"]["status"] == "findings"
    assert "(PATHCHECK MACHINE BLOCK / NOSE LEAST -11.1500)" in reply["gcode"]


def test_machine_check_alone_takes_the_default_clearance(client, root):
    reply = _check(client, root, machine_check=True)
    assert reply["ok"], reply
    m = reply["results"]["machine"]
    assert m["clearance"] == 1.0 and len(m["findings"]) == 1
    assert abs(m["findings"][0]["axes"]["Z"] - (1.0 - 8.85)) < 0.01
    plain = _check(client, root)
    assert plain["ok"] and plain["results"]["machine"] is None


@pytest.mark.parametrize("field", ["machine_check", "machine_clearance"])
def test_a_machine_without_components_names_the_field(client, root, field):
    reply = _check(client, root, machine="bare.toml",
                   **{field: True if field == "machine_check" else 0.5})
    assert reply["ok"] is False and reply["error"]["code"] == "request", reply
    assert reply["error"]["message"].startswith(
        f"field '{field}': machine 'linuxcnc-head-head-ac' has no components")


@pytest.mark.parametrize("clearance", [-1, 10001, "near"])
def test_a_clearance_out_of_range_fails_validation(client, root, clearance):
    reply = _check(client, root, machine_clearance=clearance)
    assert reply["ok"] is False and reply["error"]["code"] == "request", reply
    assert "machine_clearance" in reply["error"]["message"]


def test_without_the_collision_library_the_error_names_the_extra(root, monkeypatch):
    """In process (the worker's op): `coal` reported missing."""
    import checker.extras
    from checker.errors import PathcheckError
    from checker.service import ops
    from checker.service import protocol as p
    from checker.service.part_cache import PartCache

    real = checker.extras.find_spec
    monkeypatch.setattr(checker.extras, "find_spec",
                        lambda name: None if name == "coal" else real(name))
    state = ops.WorkerState(default_config(), PartCache(10 ** 8))
    req = p.REQUEST.validate_python({"op": "check", "apt_path": str(root / "descent.apt"),
                                     "machine": str(root / "head.toml"), "machine_check": True})
    with pytest.raises(PathcheckError) as err:
        ops.check(req, state)
    assert err.value.code == "extra"
    assert "pip install 'pathcheck[machine]'" in str(err.value)
