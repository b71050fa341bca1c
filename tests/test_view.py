"""The 3-D view's scene and page (checker/view, `pathcheck view`, `--view`): the decimation's
bound, the tool outlines against the cutter's closed forms, and on a real job (amorim
Interface-glue with its STL) the path's segments and kinds against the CL file's motions, every
finding's marker at the document's position, the page self-contained and within 5 MB."""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from checker.cutter import parse_cutter
from checker.verdict import FINDINGS
from checker.view.decimate import cluster, decimate
from checker.view.tool_outline import tool_outlines

AMORIM = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "amorim-solidworkscam-apt"
GLUE = AMORIM / "Interface-glue.apt"
REPO = Path(__file__).resolve().parents[1]
MB = 1_000_000


def arr(b64: str, dtype: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), dtype=np.dtype(dtype).newbyteorder("<"))


def scene_of(html: str) -> dict:
    text = re.search(r'<script type="application/json" id="scene">(.*?)</script>', html,
                     re.S).group(1)
    return json.loads(text)


def sphere(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere of radius 10 mm: n x 2n quads."""
    th, ph = np.meshgrid(np.linspace(0, np.pi, n + 1), np.linspace(0, 2 * np.pi, 2 * n + 1),
                         indexing="ij")
    v = 10.0 * np.column_stack([(np.sin(th) * np.cos(ph)).ravel(),
                                (np.sin(th) * np.sin(ph)).ravel(), np.cos(th).ravel()])
    i, j = np.meshgrid(np.arange(n), np.arange(2 * n), indexing="ij")
    a = (i * (2 * n + 1) + j).ravel()
    b, c, d = a + 1, a + 2 * n + 1, a + 2 * n + 2
    return v, np.concatenate([np.column_stack([a, c, b]), np.column_stack([b, c, d])])


def test_decimation_keeps_the_surface_within_its_cell():
    v, t = sphere(120)
    dv, dt, cell = decimate(v, t, 5_000)
    assert 0 < len(dt) <= 5_000 < len(t) and cell > 0
    # a merged vertex is the mean of its cell's vertices: within the cell's diagonal of the
    # sphere, which is convex (the mean lies inside, never outside)
    r = np.linalg.norm(dv, axis=1)
    assert r.max() <= 10.0 + 1e-9 and r.min() >= 10.0 - np.sqrt(3) * cell
    assert dt.max() < len(dv) and len(np.unique(np.sort(dt, axis=1), axis=0)) == len(dt)
    small = decimate(v, t, len(t))
    assert small[2] == 0.0 and len(small[1]) == len(t)
    # a cell larger than the mesh collapses everything
    assert len(cluster(v, t, 100.0)[1]) == 0


def _outline(cutter: str, piece: str = "body") -> np.ndarray:
    import dataclasses

    c = parse_cutter(cutter)
    if piece != "body":
        c = dataclasses.replace(c, flute_length=20.0, shank_diameter=8.0, stickout=40.0,
                                holder_diameter=30.0, holder_length=25.0)
    return np.array(next(o["outline"] for o in tool_outlines(c) if o["piece"] == piece))


def test_tool_outlines_are_the_cutters_profiles():
    ball = _outline("CUTTER/10,5")  # r = 5: the tip's sphere, centre 5 mm up the axis
    assert ball[0].tolist() == [0.0, 0.0] and ball[-1][0] == 0.0
    lower = ball[ball[:, 1] < 5.0 - 1e-6]
    assert len(lower) > 5
    np.testing.assert_allclose(np.hypot(lower[:, 0], lower[:, 1] - 5.0), 5.0, atol=2e-4)
    assert ball[:, 0].max() == pytest.approx(5.0, abs=1e-4)
    bull = _outline("CUTTER/10,2")  # corner radius 2 about (3, 2)
    corner = bull[(bull[:, 0] > 3.0 + 1e-6) & (bull[:, 1] < 2.0 - 1e-6)]
    np.testing.assert_allclose(np.hypot(corner[:, 0] - 3.0, corner[:, 1] - 2.0), 2.0, atol=2e-4)
    flat = _outline("CUTTER/10")
    assert flat[:, 0].max() == 5.0 and flat[1].tolist() == [5.0, 0.0]
    shank, holder = _outline("CUTTER/8", "shank"), _outline("CUTTER/8", "holder")
    assert shank[:, 0].max() == 4.0 and (shank[0, 1], shank[-1, 1]) == (20.0, 40.0)
    assert holder[:, 0].max() == 15.0 and (holder[0, 1], holder[-1, 1]) == (40.0, 65.0)


@pytest.fixture(scope="module")
def glue(tmp_path_factory):
    """Interface-glue checked, its view written by `pathcheck view`."""
    if not GLUE.is_file():
        pytest.skip(f"{GLUE} not present")
    from checker.check import check_job

    out = tmp_path_factory.mktemp("glue")
    doc = check_job(GLUE)
    results = out / "glue.json"
    results.write_text(doc.model_dump_json())
    html = out / "glue.html"
    run = subprocess.run([sys.executable, "-m", "checker.cli", "view", str(results), "-o",
                          str(html)], capture_output=True, text=True, cwd=REPO, timeout=300)
    assert run.returncode == 0, run.stderr
    return doc, html


def test_glue_page_is_self_contained_and_small(glue):
    doc, html = glue
    size = html.stat().st_size
    assert size <= 5 * MB, size
    text = html.read_text()
    # nothing to fetch: no element with a source or a link; three.js inlined with its licence
    assert not re.search(r"<(script|img|link|iframe)[^>]*\b(src|href)=", text, re.I)
    assert "three.core" in text and "Copyright" in text and "mrdoob" in text.lower()


def test_glue_path_and_markers_are_the_documents(glue):
    from checker.apt import read_cl
    from checker.config import default_config

    doc, html = glue
    scene = scene_of(html.read_text())
    m = read_cl(GLUE).motion_arrays(arc_chord_tol=default_config().check.arc_chord_tolerance)
    tip = arr(scene["path"]["positions"], "f4").reshape(-1, 3)
    kinds = arr(scene["path"]["kinds"], "u1")
    assert len(tip) == len(m) == scene["path"]["points"] and len(kinds) == len(m) - 1
    np.testing.assert_allclose(tip, m.tip, atol=1e-3 * np.abs(m.tip).max())
    finding_moves = {p.move for p in doc.points if p.verdict in FINDINGS}
    rapid_ends = np.flatnonzero(m.rapid[1:]) + 1
    assert (kinds == 0).sum() == len(set(rapid_ends) - finding_moves)
    assert (kinds >= 2).sum() == len({k for k in finding_moves if k >= 1})
    # every finding of the document has its marker at the part's deepest point (else the tip)
    found = [p for p in doc.points if p.verdict in FINDINGS]
    f = scene["findings"]
    assert f["count"] == len(found) > 1000
    at = arr(f["at"], "f4").reshape(-1, 3)
    want = np.array([p.point if p.point is not None else p.tip for p in found])
    np.testing.assert_allclose(at, want, atol=1e-4 * np.abs(want).max())
    assert arr(f["index"], "u4").tolist() == [p.index for p in found]
    verdicts = arr(f["verdict"], "u1")
    assert [FINDINGS[k] for k in verdicts] == [p.verdict for p in found]
    # the table: the deepest findings first
    depths = [r["depth"] for r in f["rows"]]
    assert depths == sorted(depths, reverse=True) and depths[0] == max(p.depth for p in found)
    # the part: the STL's triangles (small enough to keep), its bounding box
    from checker.geometry import load_part

    mesh = load_part(doc.job.part).mesh
    part = arr(scene["part"]["positions"], "f4").reshape(-1, 3)
    np.testing.assert_allclose(part.min(axis=0), mesh.vertices.min(axis=0), atol=1e-3)
    np.testing.assert_allclose(part.max(axis=0), mesh.vertices.max(axis=0), atol=1e-3)
    # 3-axis: no tool axes; the tools of the four operations
    assert scene["axes"] is None and scene["reoriented"] == []
    assert len(scene["tools"]) == len(np.unique(m.op))


def test_stock_and_fixtures_are_in_the_scene(glue):
    """The caller's stock meshes (one per operation) and fixtures, decimated to their share."""
    from checker.view.scene import STOCK_TRIANGLES, build_view

    doc, _ = glue
    v, t = sphere(200)  # 80,000 triangles each
    stocks = [(f"op {k}", v + [0, 0, k], t) for k in range(3)]
    scene = build_view(doc, stock_meshes=stocks, fixtures=[("vise.stl", v * 2, t)],
                       load_part=False)
    assert [s["label"] for s in scene["stock"]] == ["op 0", "op 1", "op 2"]
    assert all(0 < s["triangles"] <= STOCK_TRIANGLES // 3 for s in scene["stock"])
    z = arr(scene["stock"][2]["positions"], "f4").reshape(-1, 3)[:, 2]
    assert z.max() <= 12.0 + 1e-4 and z.min() >= -8.0 - 1e-4  # the third, moved 2 mm up
    assert scene["fixtures"][0]["label"] == "vise.stl"
    assert scene["box"][1][2] >= 20.0 - 1e-6  # the fixture (radius 20) is inside the box


def test_view_command_refuses_bad_input(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"schema_version": "2.0", "tool": "pathcheck"}')
    run = subprocess.run([sys.executable, "-m", "checker.cli", "view", str(bad), "-o",
                          str(tmp_path / "v.html")], capture_output=True, text=True, cwd=REPO,
                         timeout=120)
    assert run.returncode == 2
    assert "bad.json" in run.stderr and "not a pathcheck results document" in run.stderr
    assert "Traceback" not in run.stderr and len(run.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "v.html").exists()



@pytest.mark.slow
def test_check_and_check_gcode_write_their_views(tmp_path):
    """`--view` on `check` (with a stock written per operation and a fixture: both in the view)
    and on `check-gcode` (the program's own motions as the path)."""
    from checker.results import ResultsDocument

    job, part = REPO / "samples/mould/mould.apt", REPO / "samples/mould/mould.json"
    view, results, program = tmp_path / "v.html", tmp_path / "r.json", tmp_path / "m.nc"
    run = subprocess.run(
        [sys.executable, "-m", "checker.cli", str(job), "--stock", "box:+2", "--fixture",
         str(REPO / "samples/fixtures/vise.stl"), "--stock-resolution", "2", "--stock-out",
         str(tmp_path / "stock"), "--json", str(results), "-o", str(program), "--machine",
         "fanuc-hmc", "--no-store", "-q", "--view", str(view)],
        capture_output=True, text=True, cwd=REPO, timeout=600)
    assert run.returncode == 0, run.stderr
    doc = ResultsDocument.model_validate_json(results.read_text())
    scene = scene_of(view.read_text())
    assert [s["label"] for s in scene["stock"]] == ["op 1 OP1"] == \
        [f"op {o.op + 1} OP1" for o in doc.stock.operations]
    assert [f["label"] for f in scene["fixtures"]] == ["vise.stl"]
    from checker.view.scene import stl_mesh

    _, v, _ = stl_mesh("stock", doc.stock.operations[0].stl)
    stock = arr(scene["stock"][0]["positions"], "f4").reshape(-1, 3)
    np.testing.assert_allclose([stock.min(axis=0), stock.max(axis=0)],
                               [v.min(axis=0), v.max(axis=0)], atol=1e-3)
    gview = tmp_path / "g.html"
    run = subprocess.run(
        [sys.executable, "-m", "checker.cli", "check-gcode", str(program), "--machine",
         "fanuc-hmc", "--part", str(part), "--cutter", "CUTTER/10,5", "--no-store", "-q",
         "--view", str(gview), "--json", str(tmp_path / "g.json")], capture_output=True,
        text=True, cwd=REPO, timeout=600)
    assert run.returncode == 0, run.stderr
    from checker.postproc.machine import load_machine
    from checker.postproc.reader import read_gcode
    from checker.postproc.replay import part_motions, toolpath_of

    mach = load_machine("fanuc-hmc")
    motions = part_motions(read_gcode(program, mach.dialect, units=mach.units), mach)
    from checker.config import default_config

    m = toolpath_of(motions, path=program, units="mm", cutter=None).motion_arrays(
        arc_chord_tol=default_config().check.arc_chord_tolerance)
    tip = arr(scene_of(gview.read_text())["path"]["positions"], "f4").reshape(-1, 3)
    assert len(tip) == len(m) > 1000
    np.testing.assert_allclose(tip, m.tip, atol=1e-3)
    # `pathcheck view` of the G-code check's results reads the program again: the same path
    again = tmp_path / "g2.html"
    run = subprocess.run([sys.executable, "-m", "checker.cli", "view", str(tmp_path / "g.json"),
                          "-o", str(again), "--machine", "fanuc-hmc"], capture_output=True,
                         text=True, cwd=REPO, timeout=600)
    assert run.returncode == 0, run.stderr
    assert scene_of(again.read_text())["path"] == scene_of(gview.read_text())["path"]


def test_the_machined_stock_is_coloured_by_its_deviation_to_the_design(tmp_path):
    """`--view` with `--deviation-out` (PLY): each vertex of the last stock carries the
    deviation of the part's nearest measuring point, read back from the PLY here with trimesh
    and matched by a brute-force nearest search; the finishing pass leaves the parting plane's
    2 mm of stock (the box's margin) and cuts the cavity to within the tolerance."""
    trimesh = pytest.importorskip("trimesh")
    job = REPO / "samples/mould/mould.apt"
    view, results, ply = tmp_path / "v.html", tmp_path / "r.json", tmp_path / "dev.ply"
    run = subprocess.run(
        [sys.executable, "-m", "checker.cli", str(job), "--stock", "box:+2",
         "--stock-resolution", "1", "--stock-out", str(tmp_path / "stock"), "--deviation-out",
         str(ply), "--json", str(results), "--no-store", "-q", "--view", str(view)],
        capture_output=True, text=True, cwd=REPO, timeout=600)
    assert run.returncode in (0, 1), run.stderr
    scene = scene_of(view.read_text())
    last = scene["stock"][-1]
    stock = arr(last["positions"], "f4").reshape(-1, 3)
    dev = arr(last["deviation"], "f4")
    assert len(dev) == len(stock) == last["vertices"]
    cloud = trimesh.load(ply, process=False)
    points = np.asarray(cloud.vertices)
    values = np.asarray(cloud.metadata["_ply_raw"]["vertex"]["data"]["deviation"], float)
    ok = np.isfinite(values)
    pick = np.linspace(0, len(stock) - 1, 200).astype(int)
    d2 = ((stock[pick, None, :] - points[None, ok, :]) ** 2).sum(axis=2)
    np.testing.assert_allclose(dev[pick], values[ok][d2.argmin(axis=1)], atol=1e-5)
    top = stock[:, 2] > 1.5  # the stock's top at Z 2 above the parting plane at Z 0
    assert np.median(dev[top]) == pytest.approx(2.0, abs=0.1)
    assert scene["job"]["tolerance"] == pytest.approx(0.02)


def test_report_links_the_views_written_beside_it(tmp_path):
    """A job whose `JOB.view.html` is beside the report gets a link to it; the others none."""
    from synthetic_results import synthetic_document

    from checker.report import build_report
    from checker.store import ResultsStore

    now = 1_790_000_000.0
    with ResultsStore(tmp_path / "s.sqlite") as store:
        for k, name in enumerate(("jobs/mould.apt", "jobs/blade.apt")):
            store.record_job(synthetic_document(k, n=11, path=name), elapsed_s=1.0,
                             recorded_at=now - 100 + k)
        (tmp_path / "mould.view.html").write_text("<!DOCTYPE html>")
        files = build_report(store, tmp_path / "report.html", now=now)
    html = files.html.read_text()
    assert html.count('<a class="view" href="mould.view.html">3-D view</a>') == 2  # row, section
    assert "blade.view.html" not in html and html.count('class="view"') == 2
    assert "view" not in files.csv.read_text().splitlines()[0].split(",")


def test_check_gcode_view_needs_a_check(tmp_path):
    program = tmp_path / "p.nc"
    program.write_text("%\nO1\nG21 G90 G17\nG0 X0 Y0 Z10\nG1 Z0 F100\nM30\n%\n")
    run = subprocess.run([sys.executable, "-m", "checker.cli", "check-gcode", str(program),
                          "--machine", "fanuc-vmc-a", "--view", str(tmp_path / "v.html")],
                         capture_output=True, text=True, cwd=REPO, timeout=120)
    assert run.returncode == 2 and "--view shows a check" in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and not (tmp_path / "v.html").exists()


@pytest.mark.slow
def test_view_is_written_when_posting_is_refused(tmp_path):
    """Findings refuse the program (-o without --on-findings): no G-code, but the view, which
    is what shows them."""
    job = AMORIM / "RotateThin.apt"
    if not job.is_file():
        pytest.skip(f"{job} not present")
    program, view = tmp_path / "p.nc", tmp_path / "RotateThin.view.html"
    run = subprocess.run([sys.executable, "-m", "checker.cli", str(job), "-o", str(program),
                          "--view", str(view), "--no-store", "-q"], capture_output=True,
                         text=True, cwd=REPO, timeout=600)
    assert run.returncode == 1 and "not written" in run.stderr
    assert not program.exists() and scene_of(view.read_text())["findings"]["count"] > 100


def test_a_segment_takes_the_worst_verdict_of_its_move():
    from checker.view.scene import FEED, KINDS, RAPID, _segment_kinds

    class Rows:  # five motion rows, the first three rapid
        rapid = np.array([True, True, True, False, False])

        def __len__(self) -> int:
            return 5

    findings = [{"move": 3, "verdict": "crash"}, {"move": 3, "verdict": "gouge"},
                {"move": 4, "verdict": "holder"}, {"move": 0, "verdict": "gouge"}]
    kinds = _segment_kinds(Rows(), findings)
    assert [KINDS[k] for k in kinds] == ["rapid", "rapid", "crash", "holder"]
    assert kinds[0] == RAPID and _segment_kinds(Rows(), [])[2] == FEED
