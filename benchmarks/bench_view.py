"""3-D view speed and size. Run: `python -m benchmarks.bench_view [REPEATS]`.

Checks the demo job (the 4-axis compressor sample) and the amorim Interface-glue job (its STL,
7,800 moves, 11,000 findings) (not timed), writes each view (timed: scene and page), then opens
it REPEATS times (default 3) in a fresh headless Chromium (WebGL through SwiftShader, over the
DevTools pipe of tests/cdp.py): `first frame` is the page's own mark (performance.now() at the
end of its first render, ms from the start of navigation), `ready` the wall time from the
navigation command until the page says it is ready. The issue asks for 5 MB and 2 s on
Interface-glue.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from cdp import CHROMIUM, Browser  # noqa: E402

from checker.check import check_job  # noqa: E402
from checker.view.viewer_page import write_view  # noqa: E402

JOBS = {
    "demo (compressor d12)": ROOT / "samples" / "compressor" / "compressor_small_d12.apt",
    "amorim Interface-glue": ROOT.parent / "shared" / "realdata" / "amorim-solidworkscam-apt"
    / "Interface-glue.apt",
}


def main(repeats: int = 3) -> None:
    if CHROMIUM is None:
        sys.exit("bench_view: chromium not installed (bash tools/test-setup.sh)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, job in JOBS.items():
            if not job.is_file():
                print(f"{name}: {job} not present, skipped")
                continue
            doc = check_job(job)
            t0 = time.perf_counter()
            html = write_view(Path(tmp) / f"{job.stem}.html", doc)
            write_s = time.perf_counter() - t0
            first, ready = [], []
            for k in range(repeats):
                browser = Browser(Path(tmp) / f"profile-{job.stem}-{k}")
                try:
                    t1 = time.perf_counter()
                    browser.open(html.as_uri(), "document.body.dataset.ready === '1'")
                    ready.append(time.perf_counter() - t1)
                    first.append(float(browser.evaluate("document.body.dataset.firstFrame")))
                finally:
                    browser.close()
            rows.append((name, html.stat().st_size / 1e6, write_s, statistics.median(first),
                         max(first), statistics.median(ready)))
    print(f"{'job':24s} {'MB':>5s} {'write s':>8s} {'first frame ms (median, max)':>29s} "
          f"{'ready s':>8s}")
    for name, mb, write_s, med, worst, rdy in rows:
        print(f"{name:24s} {mb:5.2f} {write_s:8.2f} {med:17.0f} {worst:11.0f} {rdy:8.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
