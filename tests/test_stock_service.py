"""The service's `check` with a stock and fixtures, over a real ZeroMQ broker and a worker
process whose roots are one folder: the mould sample in a vise (`tests/vise.py`). The reply's
`stock` section validates against the published results schema and holds the moved jaw's
crashes where the geometry puts them; files outside the roots are `forbidden`, a bad stock is a
one-line `usage` error, a resolution out of range fails validation."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import jsonschema
import pytest
from brokers import client_of_root
from vise import MOULD, gotos, into_jaw, vise, write_boxes

from checker.client import Client
from checker.resources import resource

TOLERANCE = 0.02


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    """The service's one root: the mould job with its part, the vise clear and moved, and a
    stock solid (the box stock as STL) named relative to the root."""
    folder = tmp_path_factory.mktemp("stock-root")
    for name in ("mould.apt", "mould.json"):
        shutil.copy(MOULD / name, folder / name)
    vise(folder / "vise.stl")
    vise(folder / "vise_in.stl", moved=True)
    write_boxes(folder / "bar.stl", [((-82.0, -57.0, -25.0), (82.0, 57.0, 2.0))])
    return folder


@pytest.fixture(scope="module")
def client(root):
    with client_of_root(root) as c:
        yield c


def _check(client: Client, root: Path, **fields) -> dict:
    return client.call("check", apt_path=str(root / "mould.apt"), **fields)


def test_a_check_with_a_stock_and_the_moved_jaw_returns_its_crashes(client, root):
    schema = json.loads(resource("schemas", "results.schema.json").read_text())
    clean = _check(client, root, stock="box:+2", fixtures=["vise.stl"], stock_resolution=0.5)
    assert clean["ok"], clean
    jsonschema.validate(clean["results"], schema)
    s = clean["results"]["stock"]
    assert s["counts"]["crash"] == 0 and s["fixtures"] == ["vise.stl"]
    assert s["resolution"] == 0.5 and s["final_stl"] is None  # the service writes no stock
    assert clean["results"]["summary"]["status"] == "ok"
    hit = _check(client, root, stock="box:+2", fixtures=["vise_in.stl"], stock_resolution=0.5)
    assert hit["ok"], hit
    jsonschema.validate(hit["results"], schema)
    findings = hit["results"]["stock"]["findings"]
    lines, tips = gotos(root / "mould.apt")
    must, never = into_jaw(lines, tips, TOLERANCE)
    reported = {f["line"] for f in findings}
    assert must <= reported and not reported & never
    assert {(f["verdict"], f["against"]) for f in findings} == {("crash", "vise_in.stl")}
    assert max(f["depth"] for f in findings) == pytest.approx(3.0, abs=1e-6)
    assert hit["results"]["summary"]["status"] == "findings"
    # the same material removed as in the clean check: the vise takes nothing from the stock
    assert hit["results"]["stock"]["volume_final"] == pytest.approx(s["volume_final"], rel=1e-12)


def test_a_stock_solid_is_named_relative_to_the_root(client, root):
    """The worker's working folder is not the root: the stock's file is found through the
    roots as every other file of the request."""
    assert Path.cwd().resolve() != root.resolve()
    reply = _check(client, root, stock="bar.stl", stock_resolution=0.5)
    assert reply["ok"], reply
    s = reply["results"]["stock"]
    assert s["stock"].endswith("bar.stl")
    assert s["volume_initial"] == pytest.approx(164 * 114 * 27, rel=5e-3)


@pytest.mark.parametrize("fields", [
    {"fixtures": ["/etc/hosts.stl"]},
    {"fixtures": ["../outside.stl@0,0,0,0,0,1"]},
    {"stock": "/etc/stock.stl"},
    {"stock": "../../stock.step"},
])
def test_files_outside_the_roots_are_forbidden(client, root, fields):
    reply = _check(client, root, **fields)
    assert reply["ok"] is False and reply["error"]["code"] == "forbidden", reply
    assert "outside the service's roots" in reply["error"]["message"]


@pytest.mark.parametrize("stock, said", [
    ("box:+x", "--stock 'box:+x': expected box:+M"),
    ("cylinder:q:+2", "--stock 'cylinder:q:+2': expected cylinder:AXIS"),
    ("pyramid:3", "--stock 'pyramid:3': expected box:+M"),
    ("cl", "{apt}: --stock cl: the CL file states no stock"),
])
def test_a_bad_stock_is_a_one_line_usage_error(client, root, stock, said):
    reply = _check(client, root, stock=stock)
    said = said.format(apt=root / "mould.apt")
    assert reply["ok"] is False, reply
    error = reply["error"]
    assert error["code"] == "usage" and error["message"].startswith(said)
    assert "\n" not in error["message"]


def test_a_missing_fixture_inside_the_root_is_named(client, root):
    reply = _check(client, root, stock="box:+2", fixtures=["nothing.stl"])
    assert reply["ok"] is False and reply["error"]["code"] == "input", reply
    assert reply["error"]["message"].startswith("nothing.stl: field 'fixtures': expected")


@pytest.mark.parametrize("resolution", [0, 0.0001, 101, -1])
def test_a_resolution_out_of_range_fails_validation(client, root, resolution):
    reply = _check(client, root, stock="box:+2", stock_resolution=resolution)
    assert reply["ok"] is False and reply["error"]["code"] == "request", reply
    assert reply["error"]["message"].startswith("field 'stock_resolution': ")
