"""The 3-D view as a browser shows it: Debian's headless Chromium (WebGL through SwiftShader),
driven over the DevTools protocol (tests/cdp.py), opens the views of the demo job (the 4-axis
compressor sample, findings), of a real amorim job and of the 5-axis impeller sample checked
with --reorient. The page reports its camera; the test projects the document's findings with
it and finds their verdict's colour there and the part's shading on the part; a real click on
the first row of the findings table puts the tool at that pose (the page's state says so and
the tool's colour is on screen where the tool is projected); no console error, no request
beyond the file itself and its blob: modules."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from cdp import CHROMIUM, Browser

from checker.verdict import FINDINGS

REPO = Path(__file__).resolve().parents[1]
AMORIM = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "amorim-solidworkscam-apt"
WIDTH, HEIGHT = 1280, 800
BACKGROUND = np.array([0xF4, 0xF5, 0xF7])
VERDICT_RGB = {"gouge": (0xD6, 0x27, 0x28), "interference": (0xFF, 0x7F, 0x0E),
               "holder": (0x94, 0x67, 0xBD), "crash": (0x8B, 0x00, 0x00)}

pytestmark = [
    pytest.mark.skipif(CHROMIUM is None,
                       reason="chromium not installed; run `bash tools/test-setup.sh`"),
    pytest.mark.slow,
]


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    b = Browser(tmp_path_factory.mktemp("profile"), WIDTH, HEIGHT)
    yield b
    b.close()


def _view(tmp_path_factory, job: Path, **options):
    from checker.check import check_job
    from checker.check.options import CheckOptions
    from checker.view.viewer_page import write_view

    if not job.is_file():
        pytest.skip(f"{job} not present")
    doc = check_job(job, options=CheckOptions(**options))
    html = write_view(tmp_path_factory.mktemp(job.stem) / f"{job.stem}.html", doc)
    return doc, html


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    return _view(tmp_path_factory, REPO / "samples" / "compressor" / "compressor_small_d12.apt")


@pytest.fixture(scope="module")
def amorim(tmp_path_factory):
    return _view(tmp_path_factory, AMORIM / "RotateThin.apt")


@pytest.fixture(scope="module")
def impeller(tmp_path_factory):
    return _view(tmp_path_factory, REPO / "samples" / "impeller" / "passage.apt", reorient=True)


def _open(browser: Browser, html: Path) -> dict:
    browser.console_errors.clear()
    browser.requests.clear()
    browser.open(html.as_uri(), "document.body.dataset.ready === '1'")
    return json.loads(browser.evaluate("document.body.dataset.camera"))


def project(camera: dict, points: np.ndarray) -> np.ndarray:
    """(N, 2) CSS px of the viewport of part-frame points, with the page's camera (column-major
    view and projection matrices)."""
    V = np.array(camera["view"]).reshape(4, 4).T
    P = np.array(camera["proj"]).reshape(4, 4).T
    h = np.c_[points, np.ones(len(points))] @ (P @ V).T
    ndc = h[:, :3] / h[:, 3:]
    x = camera["left"] + (ndc[:, 0] + 1) / 2 * camera["width"]
    y = camera["top"] + (1 - ndc[:, 1]) / 2 * camera["height"]
    return np.c_[x, y]


def _inside(camera: dict, xy: np.ndarray, margin: float = 8.0) -> np.ndarray:
    return ((xy[:, 0] > camera["left"] + margin) & (xy[:, 0] < camera["left"] + camera["width"]
            - margin) & (xy[:, 1] > camera["top"] + margin)
            & (xy[:, 1] < camera["top"] + camera["height"] - margin))


def _clean(browser: Browser, html: Path) -> None:
    assert browser.console_errors == []
    others = [u for u in browser.requests if u != html.as_uri()
              and not u.startswith(("blob:", "data:"))]
    assert others == [], others


def _shows_findings_and_part(browser: Browser, doc, html: Path):
    camera = _open(browser, html)
    shot = browser.screenshot().astype(int)
    assert shot.shape[:2] == (HEIGHT, WIDTH)
    found = [p for p in doc.points if p.verdict in FINDINGS]
    assert found
    at = np.array([p.point if p.point is not None else p.tip for p in found])
    xy = project(camera, at)
    inside = _inside(camera, xy)
    assert inside.mean() > 0.9  # the view is fitted to the job
    # markers are squares of `size` px drawn over everything: the pixel at each marker's
    # centre has the colour of a marker that covers it (its own or one drawn after it)
    size = browser.evaluate("window.pathcheckView.markerPx")
    px = np.floor(xy).astype(int)
    hits, miss = 0, []
    for i in np.flatnonzero(inside):
        gap = np.abs(xy - xy[i]).max(axis=1)
        wants = {VERDICT_RGB[found[j].verdict] for j in np.flatnonzero(gap <= size / 2 + 1.5)}
        got = shot[px[i, 1], px[i, 0]]
        if any(np.abs(got - np.array(w)).max() <= 24 for w in wants):
            hits += 1
        else:
            miss.append((int(i), xy[i].tolist(), got.tolist(), wants))
    assert hits >= 20 and not miss, (hits, miss)
    # the part: its vertices land on shaded pixels, not on the background
    from checker.geometry import load_part
    from checker.geometry.tessellate import part_triangles

    part = load_part(doc.job.part)
    tris = part_triangles(part, 0.05, __import__("checker.config", fromlist=["x"])
                          .default_config().geometry)
    v = tris.vertices[np.linspace(0, len(tris.vertices) - 1, 400).astype(int)]
    vxy = project(camera, v)
    ok = _inside(camera, vxy)
    vpx = np.floor(vxy[ok]).astype(int)
    on_part = np.abs(shot[vpx[:, 1], vpx[:, 0]] - BACKGROUND).max(axis=1) > 12
    assert on_part.mean() > 0.9, on_part.mean()
    _clean(browser, html)
    return camera, shot


def _click_first_row(browser: Browser, table: str) -> dict:
    rect = json.loads(browser.evaluate(
        f"JSON.stringify(document.querySelector('#{table} tbody tr').getBoundingClientRect())"))
    browser.click(rect["x"] + rect["width"] / 2, rect["y"] + rect["height"] / 2)
    end = time.monotonic() + 10
    while not browser.evaluate("Boolean(document.body.dataset.selected)"):
        assert time.monotonic() < end, "no pose selected by the click"
        time.sleep(0.05)
    time.sleep(0.3)  # the frame after the click
    return json.loads(browser.evaluate("document.body.dataset.selected"))


def _tool_on_screen(browser, doc, camera, before, selected) -> None:
    """The second screenshot shows the tool body's teal along the pose's axis where the first
    did not."""
    after = browser.screenshot().astype(int)
    d = float(doc.operations[selected["op"]].cutter.split("/")[1].split(",")[0])
    tip, axis = np.array(selected["tip"]), np.array(selected["axis"])
    along = tip + np.outer(np.linspace(0.5, 3.5, 8) * d, axis)
    xy = np.floor(project(camera, along)).astype(int)

    def teal(img: np.ndarray) -> np.ndarray:
        """Per point, the teal pixels of the 9 x 9 px window about it."""
        n = []
        for x, y in xy:
            win = img[y - 4:y + 5, x - 4:x + 5].reshape(-1, 3)
            n.append(int(((win[:, 1] - win[:, 0] > 30) & (win[:, 2] - win[:, 0] > 30)
                          & (np.abs(win[:, 1] - win[:, 2]) < 30)).sum()))
        return np.array(n)

    gained = teal(after) - teal(before)
    assert (gained >= 20).sum() >= 4, (teal(after), teal(before))
    assert np.abs(after - before).max(axis=2).sum() > 0


def test_demo_job(browser, demo):
    doc, html = demo
    camera, before = _shows_findings_and_part(browser, doc, html)
    # the path is one LineSegments of one geometry: two vertices a segment, every segment
    from test_view import scene_of

    lines = json.loads(browser.evaluate(
        "JSON.stringify((() => { const out = []; window.pathcheckView.scene.traverse((o) => {"
        " if (o.isLine) out.push([o.name, o.geometry.getAttribute('position').count,"
        " o.geometry.index ? o.geometry.index.count : 0]); }); return out; })())"))
    points = scene_of(html.read_text())["path"]["points"]
    assert [x for x in lines if x[0] == "path"] == [["path", 2 * (points - 1),
                                                       2 * (points - 1)]]
    assert len(lines) <= 3  # the path, the axes as written and the CAM's: not one per move
    scene_row = browser.evaluate("JSON.stringify(window.pathcheckView.firstRow)")
    selected = _click_first_row(browser, "findings")
    first = json.loads(scene_row)
    assert selected["index"] == first["index"]
    p = doc.points[selected["index"]]
    np.testing.assert_allclose(selected["tip"], p.tip, atol=1e-9)
    np.testing.assert_allclose(selected["axis"], p.axis, atol=1e-9)
    assert selected["line"] == p.line and p.verdict in FINDINGS
    pos = browser.evaluate(f"window.pathcheckView.tools['{p.op}'].position.toArray()")
    np.testing.assert_allclose(pos, p.tip, atol=1e-9)
    assert browser.evaluate(f"window.pathcheckView.tools['{p.op}'].visible")
    _tool_on_screen(browser, doc, camera, before, selected)
    _clean(browser, html)


def test_clicking_a_marker_selects_its_finding(browser, demo):
    """A real click on an isolated marker shows the tool at that finding's pose."""
    doc, html = demo
    camera = _open(browser, html)
    found = [p for p in doc.points if p.verdict in FINDINGS]
    xy = project(camera, np.array([p.point if p.point is not None else p.tip for p in found]))
    size = browser.evaluate("window.pathcheckView.markerPx")
    gap = np.abs(xy[:, None] - xy[None]).max(axis=2) + np.eye(len(xy)) * 1e9
    alone = np.flatnonzero((gap.min(axis=1) > 3 * size) & _inside(camera, xy, 40))
    assert len(alone) > 0
    i = alone[0]
    browser.click(*xy[i])
    end = time.monotonic() + 10
    while not browser.evaluate("Boolean(document.body.dataset.selected)"):
        assert time.monotonic() < end, "no pose selected by the click"
        time.sleep(0.05)
    selected = json.loads(browser.evaluate("document.body.dataset.selected"))
    assert selected["index"] == found[i].index
    np.testing.assert_allclose(selected["tip"], found[i].tip, atol=1e-4)  # float32 markers
    _clean(browser, html)


def test_orbit_fit_and_section(browser, demo):
    """A drag orbits the camera, `fit` brings it back, the section plane at the part's median
    height leaves fewer of its pixels (those above it are cut away)."""
    doc, html = demo
    camera = _open(browser, html)
    shot = browser.screenshot().astype(int)
    cx, cy = camera["left"] + camera["width"] / 2, camera["top"] + camera["height"] / 2
    browser.drag((cx, cy), (cx + 150, cy + 40))
    time.sleep(0.3)
    moved = json.loads(browser.evaluate("document.body.dataset.camera"))
    assert np.abs(np.subtract(moved["view"], camera["view"])).max() > 0.1

    def click(selector: str) -> None:
        r = json.loads(browser.evaluate(
            f"JSON.stringify(document.querySelector('{selector}').getBoundingClientRect())"))
        browser.click(r["x"] + r["width"] / 2, r["y"] + r["height"] / 2)

    click("#fit")
    time.sleep(0.3)
    back = json.loads(browser.evaluate("document.body.dataset.camera"))
    np.testing.assert_allclose(back["view"], camera["view"], atol=1e-6)

    def shaded(img: np.ndarray) -> int:
        box = img[int(camera["top"]):int(camera["top"] + camera["height"]),
                  int(camera["left"]):int(camera["left"] + camera["width"])]
        return int((np.abs(box - BACKGROUND).max(axis=2) > 12).sum())

    # the plane at the height of the part's median vertex
    from test_view import arr, scene_of

    scene = scene_of(html.read_text())
    z = np.median(arr(scene["part"]["positions"], "f4").reshape(-1, 3)[:, 2])
    lo, hi = scene["box"][0][2], scene["box"][1][2]
    value = int(round(1000 * (z - lo) / (hi - lo)))
    browser.evaluate("(() => { const s = document.getElementById('section');"
                     f" s.value = {value}; s.dispatchEvent(new Event('input')); }})()")
    time.sleep(0.3)
    cut = browser.screenshot().astype(int)
    assert shaded(cut) < 0.85 * shaded(shot), (shaded(cut), shaded(shot), value)
    _clean(browser, html)


def test_real_amorim_job(browser, amorim):
    doc, html = amorim
    camera, before = _shows_findings_and_part(browser, doc, html)
    selected = _click_first_row(browser, "findings")
    p = doc.points[selected["index"]]
    deepest = max(q.depth for q in doc.points if q.verdict in FINDINGS)
    assert p.depth == pytest.approx(deepest) and p.verdict in FINDINGS
    np.testing.assert_allclose(selected["tip"], p.tip, atol=1e-9)
    _tool_on_screen(browser, doc, camera, before, selected)
    _clean(browser, html)


def test_impeller_shows_the_reoriented_axis(browser, impeller):
    from checker.apt import read_cl
    from checker.config import default_config

    doc, html = impeller
    _open(browser, html)
    assert browser.evaluate("document.querySelectorAll('#reoriented tbody tr').length") > 0
    selected = _click_first_row(browser, "reoriented")
    p = doc.points[selected["index"]]
    np.testing.assert_allclose(selected["axis"], p.axis, atol=1e-9)
    np.testing.assert_allclose(selected["tip"], p.tip, atol=1e-9)
    m = read_cl(doc.job.path).motion_arrays(
        arc_chord_tol=default_config().check.arc_chord_tolerance)
    np.testing.assert_allclose(selected["cam"], m.axis[p.move], atol=1e-6)
    np.testing.assert_allclose(selected["cam_tip"], m.tip[p.move], atol=1e-6)
    turned = np.degrees(np.arccos(np.clip(np.dot(selected["cam"], p.axis), -1, 1)))
    assert turned > 1.0
    # both axes drawn at the pose: the written and the CAM's
    assert browser.evaluate("window.pathcheckView.poseAxes.children.length") == 2
    _clean(browser, html)
    # along the path: the written axes, and the CAM's at every re-oriented CL pose
    from test_view import arr, scene_of

    axes = scene_of(html.read_text())["axes"]
    cl = [q for q in doc.points if q.kind == "cl"]
    turned = [q for q in cl if np.degrees(np.arccos(np.clip(np.dot(q.axis, m.axis[q.move]),
                                                             -1, 1))) > 0.1]
    assert axes["cam_count"] == len(turned) > 10
    seg = arr(axes["cam"], "f4").reshape(-1, 2, 3)
    reach = scene_of(html.read_text())["axis_reach"]
    want = np.array([m.axis[q.move] for q in turned])
    np.testing.assert_allclose(seg[:, 0], [m.tip[q.move] for q in turned], atol=1e-4)
    np.testing.assert_allclose((seg[:, 1] - seg[:, 0]) / reach, want, atol=1e-4)
    # the path is the written program's: its CL records at the written tips
    path = arr(scene_of(html.read_text())["path"]["positions"], "f4").reshape(-1, 3)
    np.testing.assert_allclose(path[[q.move for q in cl]], [q.tip for q in cl], atol=1e-4)
    assert max(np.linalg.norm(np.subtract(q.tip, m.tip[q.move])) for q in turned) > 1.0


def test_machined_stock_in_the_colours_of_its_deviation(browser, tmp_path):
    """The mould's finishing pass on a box stock 2 mm around its part, viewed with the stock
    and its deviation (--stock-out, --deviation-out): the stock's top above the parting plane
    (2 mm left) shows blue (through the stock's transparency); so does the cavity, where the
    ball leaves its scallops (tenths of a millimetre, beyond the 0.02 mm tolerance)."""
    import subprocess
    import sys

    view = tmp_path / "mould.html"
    run = subprocess.run(
        [sys.executable, "-m", "checker.cli", str(REPO / "samples/mould/mould.apt"), "--stock",
         "box:+2", "--stock-resolution", "1", "--stock-out", str(tmp_path / "stock"),
         "--deviation-out", str(tmp_path / "dev.ply"), "--no-store", "-q", "--view",
         str(view)], capture_output=True, text=True, cwd=REPO, timeout=600)
    assert run.returncode in (0, 1), run.stderr
    camera = _open(browser, view)
    for box in ("show-path", "show-part"):  # the stock alone (a user's click on each box)
        rect = json.loads(browser.evaluate(
            f"JSON.stringify(document.getElementById('{box}').getBoundingClientRect())"))
        browser.click(rect["x"] + rect["width"] / 2, rect["y"] + rect["height"] / 2)
    time.sleep(0.3)  # the frame after the clicks
    assert browser.evaluate("document.getElementById('show-path').checked") is False
    shot = browser.screenshot().astype(int)
    _clean(browser, view)
    # the parting plane's stock at Z 2 (X -80..-70, Y -50..50) and the cavity's floor cut
    # by the ball: the deepest CL tips, 5 mm below the ball's centre
    ys = np.linspace(-40.0, 40.0, 9)
    rim = np.c_[np.full(9, -75.0), ys, np.full(9, 2.0)]
    rim_rgb = shot[tuple(np.floor(project(camera, rim))[:, ::-1].astype(int).T)]
    assert ((rim_rgb[:, 2] - rim_rgb[:, 0] > 20) & (rim_rgb[:, 2] > rim_rgb[:, 1] + 8)).mean() \
        > 0.6, rim_rgb
    from checker.apt import read_cl

    m = read_cl(REPO / "samples/mould/mould.apt").motion_arrays()
    low = m.tip[np.argsort(m.tip[:, 2])[:40]]
    rgb = shot[tuple(np.floor(project(camera, low))[:, ::-1].astype(int).T)]
    assert ((rgb[:, 2] - rgb[:, 0] > 20) & (rgb[:, 2] >= rgb[:, 1])).mean() > 0.6, rgb
    # and neither is the stock's plain colour (tan): the deviation coloured it
    tan = np.array([0xC9, 0xA2, 0x7A])
    assert (np.abs(np.r_[rgb, rim_rgb] - tan).max(axis=1) > 40).mean() > 0.9
