"""The machined part against the design on a real job (docs/MATH.md §15): amorim RotateThin, whose
bore passes (a D10 on circles 0.75 mm beyond the STL's D22 bore of 36 facets) gouge 0.77-0.79 mm
into the STL by the check. The stock is a box around the bore at h = 0.05 mm (the whole part's
box holds too many rays at that spacing). The as-cut over-cut and the check's gouges agree both
ways: every gouge the check reports shows in the as-cut part at its depth (within the model's
bound), and every point the as-cut part is over-cut at lies in the cutter at a pose the check
calls a gouge. The deviation file is read back with trimesh, an independent PLY reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.stock.request import StockRequest

BORE_BOX = "box:128,31,-12,166,69,2"


@pytest.fixture(scope="module")
def rotatethin(realdata, tmp_path_factory):
    out = tmp_path_factory.mktemp("rotatethin") / "deviation.ply"
    apt = realdata / "amorim-solidworkscam-apt" / "RotateThin.apt"
    doc = check_job(apt, options=CheckOptions(stock=StockRequest(BORE_BOX, resolution=0.05,
                                                             deviation_out=out)))
    return doc, out


def test_rotatethin_overcut_agrees_with_the_checks_gouges(rotatethin):
    doc, path = rotatethin
    m = doc.stock.machined
    gouges = [p for p in doc.points if p.verdict == "gouge"]
    assert gouges and {p.op for p in gouges} == {5}
    depth = np.array([p.depth for p in gouges])
    assert m.gouge_points > 1000 and len(m.overcut) == 1 and m.overcut[0].op == 5
    assert m.bound_max == pytest.approx(0.025 + 0.05 / np.sqrt(2))
    # the deepest over-cut is the check's deepest gouge (0.79 mm, mid-facet), within the bound
    assert m.overcut_max == pytest.approx(depth.max(), abs=m.bound_max)
    assert doc.summary.status == "findings"
    ply = trimesh.load(path, process=False)
    dev = np.asarray(ply.metadata["_ply_raw"]["vertex"]["data"]["deviation"], float)
    V = np.asarray(ply.vertices)
    beyond = dev < -(doc.operations[5].tolerance + m.bound_max)
    assert beyond.sum() >= m.gouge_points * 0.9
    # check -> as cut: every gouge's deepest point has over-cut points within 0.25 mm, and
    # the deepest of them within 0.5 mm is as deep as the check's gouge, within the bound
    over = cKDTree(V[beyond])
    dist, _ = over.query([p.point for p in gouges])
    assert dist.max() < 0.25
    near = over.query_ball_point([p.point for p in gouges], 0.5)
    as_cut = np.array([(-dev[beyond][ix]).max() for ix in near])
    assert np.all(np.abs(as_cut - depth) <= m.bound_max)
    # as cut -> check: every over-cut point lies in the cutter (R 5, above its tip) at a pose
    # the check calls a gouge, within the bound
    tips = np.array([p.tip for p in gouges])
    by_xy = cKDTree(tips[:, :2])
    for v, poses in zip(V[beyond], by_xy.query_ball_point(V[beyond][:, :2], 5.0 + m.bound_max),
                        strict=True):
        assert poses and (v[2] >= tips[poses, 2] - m.bound_max).any()


def test_deviation_ply_reads_back_with_the_documents_numbers(rotatethin):
    doc, path = rotatethin
    m = doc.stock.machined
    ply = trimesh.load(path, process=False)
    data = ply.metadata["_ply_raw"]["vertex"]["data"]
    assert len(ply.vertices) == m.points
    assert m.deviation_file == str(path) and Path(m.picture).stat().st_size > 10_000
    dev = np.asarray(data["deviation"], float)
    covered = np.isfinite(dev)
    assert (~covered).sum() == m.uncovered
    assert -dev[covered].min() == pytest.approx(m.overcut_max, abs=1e-5)   # float32
    assert dev[covered].max() == pytest.approx(m.left_max, abs=1e-5)
    n = np.column_stack([data["nx"], data["ny"], data["nz"]])
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)


def test_report_shows_the_deviation_picture_and_the_rest_machining_advice(rotatethin,
                                                                        tmp_path):
    import json
    import re

    from checker.report import build_report
    from checker.store import ResultsStore

    doc, _ = rotatethin
    m = doc.stock.machined
    with ResultsStore(tmp_path / "s.sqlite") as store:
        store.record_job(doc, elapsed_s=1.0)
        files = build_report(store, tmp_path / "report.html")
    html = files.html.read_text()
    assert "The machined part against the design (top view): over-cut up to 0.79 mm" in html
    assert len(re.findall(r'<img [^>]*src="data:image/png;base64,', html)) >= 5
    assert m.advice and m.advice.startswith("rest machining:") and m.advice in html
    row = json.loads(files.json.read_text())["jobs"][0]
    assert row["rest_machining"] == m.advice
    assert f"as cut: over-cut {m.overcut_max:.3g} mm ({m.gouge_points} points gouged)" in row[
        "stock"]


def test_rotatethin_on_the_whole_box_at_its_default_resolution(realdata):
    """`box:+2` around the whole part (h = 0.5 mm by default: the bound is 0.60 mm on a wall):
    the over-cut is the bore's alone, as deep as the check's gouges within that bound."""
    apt = realdata / "amorim-solidworkscam-apt" / "RotateThin.apt"
    doc = check_job(apt, options=CheckOptions(stock=StockRequest("box:+2")))
    m = doc.stock.machined
    depth = max(p.depth for p in doc.points if p.verdict == "gouge")
    assert doc.stock.resolution == 0.5 and m.gouge_points > 0
    assert {r.op for r in m.overcut} == {5}
    assert m.overcut_max == pytest.approx(depth, abs=m.bound_max)
    for r in m.overcut:                       # on the bore: 11 mm about (146.85, 50)
        assert abs(np.hypot(r.point[0] - 146.85, r.point[1] - 50.0) - 11.0) < 1.0 + m.bound_max
