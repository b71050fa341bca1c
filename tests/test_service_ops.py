"""The `allowable` and `check` ops against the library called directly (an independent path to
the same numbers), analytic cases, the part cache, and one round trip over a real socket."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from brokers import running_broker

from checker import check as job_module
from checker import engine
from checker.config import default_config
from checker.service.ops import WorkerState
from checker.service.part_cache import PartCache
from checker.service.recorder import NullRecorder
from checker.service.replies import AllowablePoint
from checker.service.worker import handle

REPO = Path(__file__).resolve().parents[1]
MOULD = REPO / "samples" / "mould" / "mould.json"
CUTTER = "CUTTER/12,3"
SMALL = REPO / "samples" / "compressor" / "compressor_small"


def _call(state: WorkerState, recorder=None, **request) -> dict:
    reply, meta = handle(json.dumps(request).encode(), state, recorder or NullRecorder())
    assert meta["ok"] == reply["ok"] and meta["op"] == request["op"]
    return reply


@pytest.fixture(scope="module")
def state() -> WorkerState:
    return WorkerState(config=default_config(), cache=PartCache(1 << 30))


@pytest.fixture(scope="module")
def mould_rows() -> np.ndarray:
    """4 CC rows [x, y, z, nx, ny, nz] inside the mould's first surface."""
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate

    surface = load_part(MOULD).surfaces[0]
    (u0, u1), (v0, v1) = surface.domain
    t = np.array([0.3, 0.45, 0.6, 0.7])
    ev = evaluate(surface, u0 + (u1 - u0) * t, v0 + (v1 - v0) * t[::-1])
    return np.hstack([ev.points, ev.normals])


def test_allowable_matches_the_library_and_caches_the_part(state, mould_rows):
    from checker.cutter import parse_cutter
    from checker.geometry import load_part
    from checker.geometry.sampling import sample_part

    request = {"op": "allowable", "id": 3, "part": {"path": str(MOULD)},
               "cc": mould_rows.tolist(), "cutter": CUTTER}
    first = _call(state, **request)
    assert first["ok"], first
    assert first["cached"] is False and first["timing"]["sample_s"] > 0
    part = load_part(MOULD)
    direct = engine.allowable(sample_part(part, geometry=default_config().geometry), part,
                              parse_cutter(CUTTER), mould_rows[:, :3], mould_rows[:, 3:],
                              (0.0, 0.0, 1.0))
    points = [AllowablePoint.model_validate(p) for p in first["points"]]
    assert [p.index for p in points] == [0, 1, 2, 3]
    got = np.array([np.inf if p.allowable is None else p.allowable for p in points])
    np.testing.assert_allclose(got, direct.size, atol=1e-6)  # the document rounds to 1e-6
    assert [p.advice for p in points] == [str(v) for v in direct.advice]
    np.testing.assert_allclose([p.cc for p in points], mould_rows[:, :3], atol=1e-6)
    finite = np.isfinite(direct.size)
    np.testing.assert_allclose(
        [p.limiting_point for p, f in zip(points, finite, strict=True) if f],
        direct.limiting_point[finite], atol=1e-6)

    second = _call(state, **request)
    assert second["cached"] is True and second["part_hash"] == first["part_hash"]
    assert second["timing"]["load_s"] == 0 and second["timing"]["sample_s"] == 0
    assert [p["allowable"] for p in second["points"]] == [p["allowable"] for p in first["points"]]
    stats = _call(state, op="stats")["cache"]
    assert stats["entries"] >= 1 and stats["hits"] >= 1 and stats["bytes"] > 1000


def test_inline_geomdl_part_gives_the_same_answer(state, mould_rows):
    rows = mould_rows[:2].tolist()
    by_path = _call(state, op="allowable", part={"path": str(MOULD)}, cc=rows, cutter=CUTTER)
    inline = _call(state, op="allowable", part={"geomdl": json.loads(MOULD.read_text())},
                   cc=rows, cutter=CUTTER)
    assert inline["ok"], inline
    assert inline["part_hash"] != by_path["part_hash"]
    np.testing.assert_allclose([p["allowable"] for p in inline["points"]],
                               [p["allowable"] for p in by_path["points"]], atol=1e-6)


def _plane() -> dict:
    """A flat bicubic patch z = 0 over [-50, 50]^2 as geomdl exchange JSON (normal +z)."""
    xs = np.linspace(-50, 50, 4)
    pts = [[float(x), float(y), 0.0] for x in xs for y in xs]
    knots = [0, 0, 0, 0, 1, 1, 1, 1]
    return {"shape": {"type": "surface", "count": 1, "data": [{
        "type": "spline", "rational": False, "degree_u": 3, "degree_v": 3,
        "knotvector_u": knots, "knotvector_v": knots, "size_u": 4, "size_v": 4,
        "control_points": {"points": pts}}]}}


def test_a_plane_never_limits_a_ball_or_a_bull_nose(state):
    """Analytic: on a plane with the axis along the normal nothing limits the cutter, so the
    allowable size is unbounded (null) and the cutter fits."""
    rows = [[x, y, 0.0, 0.0, 0.0, 1.0] for x, y in [(0, 0), (10, -5), (-20, 30)]]
    for cutter in ("CUTTER/10", "CUTTER/12,3"):
        reply = _call(state, op="allowable", part={"geomdl": _plane()}, cc=rows, cutter=cutter)
        assert reply["ok"], reply
        assert [p["allowable"] for p in reply["points"]] == [None, None, None]
        assert {p["advice"] for p in reply["points"]} == {"fits"}
        assert all(p["limiting_point"] is None for p in reply["points"])


def test_best_b_is_at_least_the_size_at_every_b_of_the_scan(mould_rows):
    from checker.b_axis import axis_for_b
    from checker.cutter import parse_cutter

    row = mould_rows[:1]
    base = default_config()  # a coarse refinement keeps the test short; the scan is the same
    coarse = base.model_copy(update={
        "four_axis": base.four_axis.model_copy(update={"b_tolerance": 0.5})})
    state = WorkerState(config=coarse, cache=PartCache(1 << 30))  # holding the mould only
    reply = _call(state, op="allowable", part={"path": str(MOULD)}, cc=row.tolist(),
                  cutter=CUTTER, b_range=[-4.0, 4.0])
    assert reply["ok"], reply
    point = reply["points"][0]
    assert -4.0 <= point["b_best"] <= 4.0
    entry = next(iter(state.cache.entries.values()))
    cutter = parse_cutter(CUTTER)
    grid = np.array([-4.0, -2.0, 0.0, 2.0, 4.0])
    sizes = engine.allowable(entry.test_points, entry.part, cutter, np.repeat(row[:, :3], 5, 0),
                             np.repeat(row[:, 3:], 5, 0), axis_for_b(grid)).size
    assert point["allowable_at_best"] >= sizes.max() - 1e-6
    assert point["allowable"] == pytest.approx(sizes[2], abs=1e-6)  # axis (0, 0, 1) is B = 0
    need = cutter.size + default_config().check.tolerance
    for lo, hi in point["b_feasible"]:
        assert -4.0 <= lo <= hi <= 4.0
    inside = [any(lo <= b <= hi for lo, hi in point["b_feasible"]) for b in grid]
    assert inside == [bool(s >= need) for s in sizes]


def test_library_errors_become_error_replies(state):
    rows = [[0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]
    bad_cutter = _call(state, op="allowable", part={"path": str(MOULD)}, cc=rows,
                       cutter="CUTTER/-5")
    assert bad_cutter["ok"] is False and bad_cutter["error"]["code"] != "internal"
    bad_part = _call(state, op="allowable", part={"geomdl": {"shape": {"type": "curve"}}},
                     cc=rows, cutter=CUTTER)
    assert bad_part["ok"] is False and bad_part["error"]["code"] == "part"
    outside = _call(state, op="allowable", part={"path": str(MOULD)}, cc=rows, cutter=CUTTER,
                    b_range=[-500.0, 0.0])
    assert outside["ok"] is False and "outside the machine's limits" in \
        outside["error"]["message"]


@pytest.fixture(scope="module")
def tiny_job(tmp_path_factory) -> Path:
    """The approach and first 5 feed moves of the small compressor job (4-axis, ball D6)."""
    lines = SMALL.with_suffix(".apt").read_text().splitlines()[:16]
    assert sum(text.startswith("GOTO/") for text in lines) == 6  # a rapid, then 5 feeds
    path = tmp_path_factory.mktemp("tiny") / "tiny.apt"
    path.write_text("\n".join([*lines, "END", "FINI", ""]))
    return path


def test_check_returns_the_results_document_and_records_it(state, tiny_job, tmp_path):
    from checker.results import ResultsDocument
    from checker.service.recorder import open_recorder
    from checker.store import ResultsStore

    job, part = tiny_job, SMALL.with_suffix(".json")
    recorder = open_recorder(tmp_path / "store.sqlite")
    reply = _call(state, recorder, op="check", apt=job.read_text(), part={"path": str(part)})
    assert reply["ok"], reply
    with ResultsStore(tmp_path / "store.sqlite") as store:
        (row,) = store.jobs()
        (request,) = store.requests()
        n_points = len(reply["results"]["points"])
        assert (row.source, row.job_path, row.points) == ("service", "<apt>", n_points)
        assert request[1:3] == ("check", 1) and request[5] == row.id
        assert store.document(row.id).model_dump(mode="json") == reply["results"]
    doc = ResultsDocument.model_validate(reply["results"])
    direct = job_module.check_job(job, part)
    assert doc.job.path == "<apt>" and doc.summary.points == direct.summary.points > 0
    assert [p.allowable for p in doc.points] == [p.allowable for p in direct.points]
    assert doc.summary.counts == direct.summary.counts


def test_check_errors_name_the_line_the_option_and_the_b_range(state, tiny_job):
    part = {"path": str(SMALL.with_suffix(".json"))}
    lines = SMALL.with_suffix(".apt").read_text().splitlines()
    goto = next(i for i, text in enumerate(lines) if text.startswith("GOTO"))
    broken = "\n".join([*lines[:goto], "GOTO/1.0,2.0,abc", *lines[goto + 1:]])
    bad = _call(state, op="check", apt=broken, part=part)
    assert bad["ok"] is False and bad["error"]["line"] == goto + 1
    assert bad["error"]["message"].startswith(f"<apt>:{goto + 1}: ")
    named = _call(state, op="check", apt=broken, name="blade-7", part=part)
    assert named["error"]["message"].startswith(f"blade-7.apt:{goto + 1}: ")
    bad_name = _call(state, op="check", apt=broken, name="../x", part=part)
    assert bad_name["error"]["code"] == "request" and "field 'name'" in \
        bad_name["error"]["message"]
    option = _call(state, op="check", apt="X", part=part, options={"service.debug_ops": True})
    assert option["error"]["code"] == "request" and "options.service.debug_ops" in \
        option["error"]["message"]
    value = _call(state, op="check", apt="X", part=part, options={"check.tolerance": -1})
    assert value["error"]["code"] == "request" and "options.check.tolerance" in \
        value["error"]["message"]
    b_range = _call(state, op="check", apt_path=str(tiny_job), part=part, b_range=[-500, 0])
    assert b_range["ok"] is False and "outside the machine's limits" in \
        b_range["error"]["message"]


@pytest.fixture(scope="module")
def served():
    """The address of a broker with one worker (stopped after the module)."""
    with running_broker(default_config(), workers=1) as broker:
        yield broker.address


def test_allowable_over_a_socket_hits_the_cache_the_second_time(served, mould_rows):
    from checker.client import Client

    with Client(served, timeout_s=120) as client:
        fields = {"part": {"path": str(MOULD)}, "cc": mould_rows[:1].tolist(), "cutter": CUTTER}
        first, second = (client.call("allowable", **fields) for _ in range(2))
    assert first["ok"] and second["ok"]
    assert (first["cached"], second["cached"]) == (False, True)
    assert second["points"] == first["points"]


def test_post_hook_writes_the_gcode_the_service_returns(served, tiny_job, tmp_path, capsys):
    import importlib.util

    from pygcode import Line

    spec = importlib.util.spec_from_file_location("post_hook", REPO / "samples" / "post_hook.py")
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    job, part = tiny_job, SMALL.with_suffix(".json")
    out = tmp_path / "tiny.nc"
    code = hook.main([str(job), "--part", str(part), "-o", str(out), "--address", served,
                      "--on-findings", "comment"])
    printed = capsys.readouterr()
    assert code in (0, 1), printed.err
    # the exit code is the verdict the written program states, and that is its findings
    (verdict,) = re.findall(r"^\(PATHCHECK VERDICT ([A-Z]+)", out.read_text(), flags=re.M)
    findings = [int(n) for n in re.findall(r"(\d+) (?:gouge|interference|holder|crash)",
                                           printed.out)]
    assert (verdict, code) == (("FINDINGS", 1) if sum(findings) else ("CLEAN", 0))
    refused = tmp_path / "refused.nc"
    code = hook.main([str(job), "--part", str(part), "-o", str(refused), "--address", served])
    printed = capsys.readouterr()
    if verdict == "FINDINGS":  # the default refuses it: nothing written, exit 1, why on stderr
        assert code == 1 and not refused.exists(), printed.err
        assert "G-code not written: the program has" in printed.err
    else:
        assert code == 0 and refused.is_file()
    blocks = [Line(text) for text in out.read_text().splitlines() if text.strip("% ")]
    assert any("B" in {w.letter for w in line.block.words} for line in blocks)
    assert "(TINY)" in out.read_text()  # the hook sends the job's name
    assert hook.main([str(tmp_path / "none.apt"), "--address", served]) == 2
    assert not (tmp_path / "none.nc").exists() and list(tmp_path.glob("*.tmp")) == []
