"""The report page as a browser shows it: Debian's headless Chromium renders it (no network)
to a screenshot that is not blank, and its DOM has the expected job rows and pictures."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from checker.report import build_report
from checker.report.synthetic import synthetic_document
from checker.store import ResultsStore

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync")
NOW = 1_790_000_000.0

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
    return root, files


def test_dom_has_the_job_rows_and_pictures(page):
    root, files = page
    dom = _chromium(root, "--dump-dom", files.html.as_uri()).stdout
    assert len(re.findall(r'<tr class="job (ok|findings|failed)"', dom)) == 4
    pictures = re.findall(r'<img class="pic"[^>]*src="data:image/png;base64,', dom)
    assert len(pictures) == 3 * 4 + 1 == files.pictures
    assert "pathcheck nightly report" in dom


def test_screenshot_is_not_blank(page):
    root, files = page
    shot = root / "shot.png"
    _chromium(root, f"--screenshot={shot}", "--window-size=1400,1800", "--hide-scrollbars",
              files.html.as_uri())
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert img.shape[:2] == (1800, 1400)
    ink = np.any(img < 200, axis=2)
    assert ink.mean() > 0.03  # text, table rules and pictures, not an empty white page
    # the pictures are in colour: viridis yellow/green of the allowable map is on screen
    colourful = (img.max(axis=2) - img.min(axis=2)) > 80
    assert colourful.mean() > 0.02
