"""The report page as a browser shows it: Debian's headless Chromium renders it (no network)
at 1280 px to a screenshot that is not blank; its DOM has the expected job rows and pictures,
its counts are the documents', and the pictures' legend text is at least 11 px on screen."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image
from synthetic_results import synthetic_document

from checker.config import default_config
from checker.report import build_report
from checker.report.pictures import FONT_PT
from checker.store import ResultsStore
from checker.verdict import FINDINGS

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync")
NOW = 1_790_000_000.0
WIDTH = 1280  # px, the browser window
# appended to a copy of the page: what the browser laid out, written into the DOM
MEASURE = """<script>
const shown = [...document.images].map(i => [i.getBoundingClientRect().width, i.naturalWidth]);
const out = document.createElement("pre");
out.id = "measured";
out.textContent = JSON.stringify({shown, page: document.documentElement.scrollWidth});
document.body.appendChild(out);
</script>"""

pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium not installed; run `bash tools/test-setup.sh`"
)


def _chromium(tmp_path, *args: str) -> subprocess.CompletedProcess:
    profile = tmp_path / "profile"
    return subprocess.run(
        [CHROMIUM, *FLAGS, f"--user-data-dir={profile}", *args], capture_output=True,
        text=True, timeout=120, check=True,
    )


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    root = tmp_path_factory.mktemp("page")
    with ResultsStore(root / "s.sqlite") as store:
        for k in range(3):
            store.record_job(synthetic_document(k, n=41, four_axis=k != 1), elapsed_s=1.0,
                             recorded_at=NOW - 3000 + k)
        store.record_job(None, error="jobs/x.apt:1: expected PARTNO, found garbage",
                         job_path="jobs/x.apt", elapsed_s=0.1, recorded_at=NOW - 100)
        files = build_report(store, root / "report.html", now=NOW)
    docs = [synthetic_document(k, n=41, four_axis=k != 1) for k in range(3)]
    return root, files, docs


def test_dom_has_the_job_rows_and_pictures(page):
    root, files, _ = page
    dom = _chromium(root, "--dump-dom", files.html.as_uri()).stdout
    assert len(re.findall(r'<tr class="job (ok|findings|failed)"', dom)) == 4
    pictures = re.findall(r'<img class="pic"[^>]*src="data:image/png;base64,', dom)
    assert len(pictures) == 3 * 4 + 1 == files.pictures
    assert "pathcheck nightly report" in dom


def test_screenshot_is_not_blank(page):
    root, files, _ = page
    shot = root / "shot.png"
    _chromium(root, f"--screenshot={shot}", f"--window-size={WIDTH},1800", "--hide-scrollbars",
              files.html.as_uri())
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert img.shape[:2] == (1800, WIDTH)
    ink = np.any(img < 200, axis=2)
    assert ink.mean() > 0.03  # text, table rules and pictures, not an empty white page
    # the pictures are in colour: viridis yellow/green of the allowable map is on screen
    colourful = (img.max(axis=2) - img.min(axis=2)) > 80
    assert colourful.mean() > 0.02


def test_legends_are_readable_at_1280_px(page):
    """Text of FONT_PT points in a picture of `picture_dpi` is FONT_PT * dpi / 72 image pixels;
    the browser shows the image at (laid-out width / natural width) of that: >= 11 CSS px. The
    page does not scroll sideways at 1280 px."""
    root, files, _ = page
    measured = root / "measured.html"
    measured.write_text(files.html.read_text().replace("</body>", MEASURE + "</body>"))
    dom = _chromium(root, "--dump-dom", f"--window-size={WIDTH},1800", measured.as_uri()).stdout
    m = json.loads(re.search(r'<pre id="measured">(.*?)</pre>', dom, re.S).group(1)
                   .replace("&quot;", '"'))
    dpi = default_config().report.picture_dpi
    sizes = [FONT_PT * dpi / 72.0 * shown / natural for shown, natural in m["shown"]]
    assert len(sizes) == files.pictures
    assert min(sizes) >= 11.0, sizes  # 9 pt at 150 dpi shown at 96 px per inch: 12 px
    assert m["page"] <= WIDTH


def test_dom_counts_are_the_documents(page):
    """Table cells and the findings captions as the browser parsed them, against the documents
    the jobs were recorded from."""
    root, files, docs = page
    dom = _chromium(root, "--dump-dom", files.html.as_uri()).stdout
    for job_id, doc in zip((1, 2, 3), docs, strict=True):
        c = doc.summary.counts
        row = re.search(rf'<tr class="job [a-z]+" id="row-{job_id}">(.*?)</tr>', dom, re.S)
        cells = [int(x) for x in re.findall(r'<td class="n">(\d+)</td>', row.group(1))]
        assert cells[1:7] == [doc.summary.points, c.gouge, c.interference, c.holder, c.crash,
                              c.inaccessible]
        section = re.search(rf'<section class="job" id="job-{job_id}">(.*?)</section>', dom,
                            re.S).group(1)
        caption = re.search(r"<figcaption>[^<]*?(\d+) findings highlighted: (\d+) gouge, "
                            r"(\d+) interference, (\d+) holder hit, (\d+) crash", section)
        total, *each = map(int, caption.groups())
        assert each == [c.gouge, c.interference, c.holder, c.crash]
        assert total == sum(p.verdict in FINDINGS for p in doc.points) > 0
    totals = re.search(r'<p class="totals"><b>(\d+)</b> jobs: <b>(\d+)</b> clean, '
                       r'<b>(\d+)</b> with findings, <b>(\d+)</b> failed', dom).groups()
    assert [int(x) for x in totals] == [4, 0, 3, 1]
