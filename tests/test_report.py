"""The nightly report: page, pictures, JSON/CSV summary, trends, standard-cutter maps and the
`pathcheck report` command, over stores filled with synthetic 41 x 41 mould jobs."""

from __future__ import annotations

import base64
import csv
import io
import json
import re
from datetime import datetime
from html.parser import HTMLParser

import numpy as np
import pytest
from PIL import Image
from synthetic_results import synthetic_document

from checker.cli import main
from checker.errors import PathcheckError
from checker.report import build_report, parse_since
from checker.report.build import PARALLEL_FROM, POINT_COLUMNS
from checker.report.pictures import (
    CSS_PX_PER_IN,
    PANEL_IN,
    UNBOUNDED,
    JobPainter,
    b_range,
    paint_map,
)
from checker.report.standard import per_region, standard_cutters
from checker.report.trends import DAY_S, compare, nights
from checker.store import ResultsStore, point_arrays
from checker.verdict import FINDINGS

NOW = 1_790_000_000.0  # a fixed report time, UTC epoch s
PNG_SRC = re.compile(r'<img class="pic" [^>]*src="data:image/png;base64,([^"]+)"')
DPI = 150  # the default config's report.picture_dpi


def _images(html: str) -> list[Image.Image]:
    """The page's pictures as RGB (they are stored with a palette)."""
    return [Image.open(io.BytesIO(base64.b64decode(b))).convert("RGB")
            for b in PNG_SRC.findall(html)]


def _pngs(html: str) -> list[np.ndarray]:
    return [np.asarray(img) for img in _images(html)]


def _findings(doc) -> int:
    """Points of the document with a finding verdict, counted from the points themselves."""
    return sum(p.verdict in FINDINGS for p in doc.points)


@pytest.fixture(scope="module")
def night(tmp_path_factory):
    """A store with tonight 3 jobs (two 4-axis, one 3-axis) and a failed one; last night job 0
    (same result) and job 1 (failed); and the report built over it."""
    root = tmp_path_factory.mktemp("night")
    docs = [synthetic_document(k, n=41, four_axis=k != 2) for k in range(3)]
    with ResultsStore(root / "s.sqlite") as store:
        store.record_job(docs[0], elapsed_s=1.0, recorded_at=NOW - DAY_S - 600)  # last night
        for k, doc in enumerate(docs):
            store.record_job(doc, elapsed_s=2.0 + k, recorded_at=NOW - 3600 + k)
        store.record_job(None, error="jobs/bad.apt:3: expected GOTO/x,y,z, found GOTO/1,2",
                         job_path="jobs/bad.apt", elapsed_s=0.1, recorded_at=NOW - 60)
        store.record_job(None, error="part missing", job_path=docs[1].job.path, elapsed_s=0.1,
                         recorded_at=NOW - DAY_S - 300)  # last night, job 1 failed
        files = build_report(store, root / "out" / "report.html", now=NOW,
                             points_csv=root / "out" / "points.csv")
    return docs, files


def test_page_has_rows_pictures_and_no_network(night):
    docs, files = night
    html = files.html.read_text()
    assert files.jobs == 4 and files.pictures == 3 * 4 + 1
    assert len(re.findall(r'<tr class="job ', html)) == 4
    assert len(re.findall(r'<tr class="job failed"', html)) == 1
    assert "expected GOTO/x,y,z, found GOTO/1,2" in html
    images = _pngs(html)
    assert len(images) == 13
    for img in images[1:]:  # job pictures: fixed size, and more than one colour
        assert img.shape[:2] == (round(PANEL_IN[1] * DPI), round(PANEL_IN[0] * DPI))
        assert img.reshape(-1, img.shape[2]).std(axis=0).max() > 10
    # each picture records its dpi and the page shows it at its size in inches
    for img in _images(html):
        assert img.info["dpi"] == pytest.approx((DPI, DPI), abs=0.1)
    shown = [int(w) for w in re.findall(r'<img class="pic" width="(\d+)"', html)]
    assert len(shown) == 13
    assert shown[1:] == [round(PANEL_IN[0] * CSS_PX_PER_IN)] * 12
    np.testing.assert_allclose([w * DPI / CSS_PX_PER_IN for w in shown],
                               [i.shape[1] for i in images], atol=1.0)
    assert not re.search(r"(src|href)=\"(https?:)?//", html) and "<script" not in html
    # the gouge count in the table row is the document's
    row = re.search(r'id="row-2".*?</tr>', html, re.S).group(0)
    cells = re.findall(r'<td class="n">([^<]*)</td>', row)
    assert int(cells[2]) == docs[0].summary.counts.gouge  # id, points, gouges, ...
    assert "same gouges" in row  # job 0 again: compared with last night's run
    assert "previous run failed" in re.search(r'id="row-3".*?</tr>', html, re.S).group(0)
    assert "first run" in re.search(r'id="row-4".*?</tr>', html, re.S).group(0)


def test_findings_picture_marks_the_gouges(night):
    docs, files = night
    img = _pngs(files.html.read_text())[3].astype(int)  # job 1: maps, then findings
    red = (img[:, :, 0] > 200) & (img[:, :, 1] < 60) & (img[:, :, 2] < 60)
    orange = (img[:, :, 0] > 240) & (np.abs(img[:, :, 1] - 127) < 20) & (img[:, :, 2] < 40)
    assert red.sum() > 20 * docs[0].summary.counts.gouge // 4  # gouge squares are drawn
    assert orange[:, : img.shape[1] * 3 // 4].sum() > 500  # the interfering wall column


def test_json_and_csv_summaries(night):
    docs, files = night
    data = json.loads(files.json.read_text())
    assert data["totals"] == {"ok": 0, "findings": 3, "failed": 1}
    assert [j["gouge"] for j in data["jobs"][:3]] == [d.summary.counts.gouge for d in docs]
    assert data["jobs"][3]["status"] == "failed" and data["jobs"][3]["error"]
    assert data["nights"][-1]["jobs"] == 4 and data["nights"][-2]["jobs"] == 2
    assert data["nights"][-2]["failed"] == 1 and data["jobs"][1]["previous_status"] == "failed"
    rows = list(csv.DictReader(files.csv.open()))
    assert len(rows) == 4 and rows[0]["job_path"] == docs[0].job.path
    # dates: ISO 8601 with the local offset, the same instant as the store's epoch seconds
    recorded = [NOW - 3600 + k for k in range(3)] + [NOW - 60]
    for t, job, row in zip(recorded, data["jobs"], rows, strict=True):
        assert job["recorded_at"] == row["recorded_at"]
        when = datetime.fromisoformat(job["recorded_at"])
        assert when.utcoffset() is not None and when.timestamp() == t
        assert when.utcoffset() == datetime.fromtimestamp(t).astimezone().utcoffset()
    assert float(rows[1]["worst_depth"]) == pytest.approx(docs[1].summary.worst_depth)
    assert rows[0]["regions"].startswith("S0:")
    assert datetime.fromisoformat(data["until"]).timestamp() == NOW
    assert datetime.fromisoformat(data["since"]).timestamp() == NOW - DAY_S
    assert datetime.fromisoformat(data["nights"][-1]["start"]).timestamp() == NOW - DAY_S
    assert data["until"] in files.html.read_text()


def test_points_csv_holds_every_point_of_the_documents(night):
    docs, files = night
    rows = list(csv.DictReader(files.points_csv.open(newline="")))
    assert tuple(rows[0]) == POINT_COLUMNS
    assert len(rows) == sum(len(d.points) for d in docs)  # the failed job has none
    for job_id, doc in zip((2, 3, 4), docs, strict=True):
        mine = [r for r in rows if int(r["job_id"]) == job_id]
        assert len(mine) == len(doc.points)
        for r, p in zip(mine, doc.points, strict=True):
            assert (int(r["index"]), int(r["operation"]), int(r["line"]), r["kind"],
                    r["verdict"], r["job_path"]) == (p.index, p.op, p.line, p.kind, p.verdict,
                                                     doc.job.path)
            assert [float(r[k]) for k in "xyz"] == list(p.tip)
            for key, value in (("depth", p.depth), ("allowable", p.allowable),
                               ("margin", p.margin), ("b", p.b), ("b_best", p.b_best)):
                assert (r[key] == "") if value is None else float(r[key]) == value
        verdicts = [r["verdict"] for r in mine]
        assert sum(v in FINDINGS for v in verdicts) == (doc.summary.counts.gouge
                                                         + doc.summary.counts.interference)


def test_empty_store_says_no_jobs(tmp_path):
    with ResultsStore(tmp_path / "s.sqlite") as store:
        files = build_report(store, tmp_path / "r.html", now=NOW)
    html = files.html.read_text()
    assert files.jobs == 0 and files.pictures == 0
    assert 'id="no-jobs"' in html and "No jobs were recorded" in html
    assert "<tr class=\"job" not in html
    assert json.loads(files.json.read_text())["jobs"] == []
    assert files.csv.read_text().count("\n") == 1  # the header only


def test_page_text_is_escaped(tmp_path):
    """A job path and an error that look like markup are shown as text (the template
    autoescapes): the parsed page has no element from them and its text has them verbatim."""
    path, error = 'jobs/<img src=x onerror="alert(1)">.apt', "</td><script>alert('x')</script> & co"
    with ResultsStore(tmp_path / "s.sqlite") as store:
        store.record_job(None, error=error, job_path=path, elapsed_s=0.1, recorded_at=NOW - 60)
        files = build_report(store, tmp_path / "r.html", now=NOW)

    class Page(HTMLParser):
        def __init__(self):
            super().__init__()
            self.tags, self.text = [], []

        def handle_starttag(self, tag, attrs):
            self.tags.append(tag)

        def handle_data(self, data):
            self.text.append(data)

    page = Page()
    page.feed(files.html.read_text())
    assert "script" not in page.tags and page.tags.count("img") == 1  # the trend picture
    text = "".join(page.text)
    assert f"failed: {error}" in text and path in text


def test_standard_cutters_against_brute_force():
    doc = synthetic_document(5, n=21)
    arrays = point_arrays(doc)
    std = standard_cutters("ball", doc.job.cutter, doc.job.cutter_size, (1.0,))
    assert all(n.startswith("BALL") for n in std.names) and np.all(np.diff(std.sizes) >= 0)
    picked = std.largest(arrays["allowable"])
    for a, k in zip(arrays["allowable"], picked, strict=True):
        fits = [i for i, s in enumerate(std.sizes) if s <= a]
        assert k == (max(fits) if fits else -1)
    regions = dict(per_region(std, arrays["allowable"], arrays["surface"]))
    for sid, name in regions.items():
        least = arrays["allowable"][arrays["surface"] == sid].min()
        assert name == std.names[std.largest(np.array([least]))[0]]
    # a family the tool library lacks: config diameters, corner radius kept (R = D/2 - r);
    # D3 has no cutter with the corner r = 2 (R = 1.5 - 2 < 0)
    apt = standard_cutters("apt", "CUTTER/10,2", 3.0, (3.0, 6.0, 12.0))
    assert apt.names == ("D6", "D12")
    np.testing.assert_allclose(apt.sizes, [1.0, 4.0])
    picked = apt.largest(np.array([0.2, 1.0, 3.9, np.nan]))
    assert [apt.name_of(k) for k in picked] == ["none", "D6", "D6", "D12"]


def test_paint_map_puts_points_where_they_are():
    target = np.zeros((101, 101, 4), dtype=np.uint8)
    xy = np.array([[0.0, 0.0], [10.0, 10.0], [10.0, 10.0]])
    rgba = np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255]], dtype=np.uint8)
    paint_map(target, xy, rgba, np.array([3, 3, 3]), np.array([0, 0, 1]))
    # square view of half-width 0.53 * 10 around (5, 5): x = 0 -> column 3, y = 10 -> row 3
    assert tuple(target[97, 3, :3]) == (255, 0, 0)
    assert tuple(target[3, 97, :3]) == (0, 0, 255)  # the later group covers the earlier
    assert tuple(target[50, 50, :3]) == (255, 255, 255)


def test_painter_path_panel_scales():
    assert b_range(np.array([-5.0, 8.0, np.nan])) == 10.0
    assert b_range(np.array([75.0])) == 90.0 and b_range(np.array([400.0])) == 180.0
    doc3 = synthetic_document(2, n=11, four_axis=False)
    painter = JobPainter()
    std = standard_cutters("ball", doc3.job.cutter, doc3.job.cutter_size, (1.0,))
    pictures, facts = painter.render(point_arrays(doc3), std, doc3.job.cutter_size, "r")
    assert len(pictures) == 4 and facts["has_b"] is False and facts["view"] == "XY"
    assert facts["symbol"] == "r"
    # the highlighted points are the findings, not every point that is not ok
    doc = synthetic_document(5, n=11, four_axis=False)
    facts = painter.render(point_arrays(doc), std, doc.job.cutter_size, "r")[1]
    c = doc.summary.counts
    assert facts["highlighted"] == _findings(doc) == c.gouge + c.interference == 13
    assert c.within_tolerance == 1  # 'not ok' would say 14


def test_allowable_map_marks_unbounded_points():
    """Unbounded (nan) allowable sizes at contacts are drawn pink, not as the largest size, on
    the allowable map and on the size-along-the-path panel of a job without B."""
    doc = synthetic_document(2, n=11, four_axis=False)
    painter = JobPainter()
    std = standard_cutters("ball", doc.job.cutter, doc.job.cutter_size, (1.0,))
    pink = np.array(Image.new("RGB", (1, 1), UNBOUNDED))[0, 0].astype(int)

    def pink_pixels(arrays) -> list[int]:
        pictures = painter.render(arrays, std, doc.job.cutter_size, "r")[0]
        out = []
        for k in (0, 3):  # allowable map, path panel
            img = np.asarray(Image.open(io.BytesIO(base64.b64decode(pictures[k]))).convert("RGB"))
            out.append(int(np.all(np.abs(img[:, :, :3].astype(int) - pink) <= 1, axis=2).sum()))
        return out

    arrays = point_arrays(doc)
    legend_only = pink_pixels(arrays)  # the legends' patch and marker
    arrays["allowable"][:20] = np.nan  # 20 contacts where nothing limits the cutter
    with_unbounded = pink_pixels(arrays)
    assert min(legend_only) > 0
    assert with_unbounded[0] > legend_only[0] + 20 * 9 and with_unbounded[1] > legend_only[1]
    arrays["contact"][:20] = False  # the same points without a contact: not drawn at all
    assert pink_pixels(arrays) == legend_only


def test_captions_count_what_the_table_and_document_count(night):
    """The findings caption, the table row and the JSON say the document's numbers."""
    docs, files = night
    html = files.html.read_text()
    data = json.loads(files.json.read_text())
    for job_id, doc, job in zip((2, 3, 4), docs, data["jobs"], strict=False):
        c = doc.summary.counts
        row = re.search(rf'id="row-{job_id}".*?</tr>', html, re.S).group(0)
        cells = [int(x) for x in re.findall(r'<td class="n">(\d+)</td>', row)[1:7]]
        assert cells == [doc.summary.points, c.gouge, c.interference, c.holder, c.crash,
                         c.inaccessible]
        section = re.search(rf'id="job-{job_id}".*?</section>', html, re.S).group(0)
        m = re.search(r"(\d+) findings highlighted: (\d+) gouge, (\d+) interference, "
                      r"(\d+) holder hit, (\d+) crash", section)
        total, *each = map(int, m.groups())
        assert each == [c.gouge, c.interference, c.holder, c.crash]
        assert total == sum(each) == _findings(doc)
        assert [job[k] for k in ("gouge", "interference", "holder", "crash")] == each
        assert f"smallest {doc.summary.largest_safe_cutter:.3g} mm" in section


def test_trends_group_by_night():
    class Row:
        def __init__(self, t, status, gouges, depth):
            self.recorded_at, self.status, self.n_gouge, self.worst_depth = t, status, gouges, depth
            self.n_interference = self.n_holder = 0

    rows = [Row(NOW - 10, "findings", 5, 0.2), Row(NOW - 20, "ok", 0, None),
            Row(NOW - DAY_S - 5, "failed", 0, None), Row(NOW - 3 * DAY_S - 5, "findings", 2, 0.1)]
    per_night = nights(rows, NOW, 5)
    assert [n["jobs"] for n in per_night] == [0, 1, 0, 1, 2]
    assert per_night[-1]["gouges"] == 5 and per_night[-1]["worst_depth"] == 0.2
    table = {q: (a, b, c) for q, a, b, c in compare(per_night)}
    assert table["jobs"] == (2, 1, 0.5) and table["failed"] == (0, 1, 0.25)
    assert table["worst depth"] == (0.2, None, 0.1)


def test_parse_since():
    assert parse_since("24h") == 86400 and parse_since("90m") == 5400
    assert parse_since("7d") == 7 * 86400 and parse_since("2") == 7200
    for bad in ("", "-3h", "soon", "0d"):
        with pytest.raises(PathcheckError, match="--since"):
            parse_since(bad)


def test_parallel_pictures_equal_in_process(tmp_path):
    with ResultsStore(tmp_path / "s.sqlite") as store:
        for k in range(PARALLEL_FROM):
            store.record_job(synthetic_document(k, n=9), elapsed_s=1.0, recorded_at=NOW - k - 1)
        many = build_report(store, tmp_path / "many.html", now=NOW)  # process pool
        one = build_report(store, tmp_path / "one.html", since_s=2.5, now=NOW)  # in process
    pics_many = PNG_SRC.findall(many.html.read_text())
    pics_one = PNG_SRC.findall(one.html.read_text())
    assert many.jobs == PARALLEL_FROM and one.jobs == 2
    # jobs are listed oldest first: the newest two jobs are the last eight job pictures
    assert pics_one[1:] == pics_many[-8:]


def test_report_command(tmp_path, monkeypatch, capsys):
    store_path = tmp_path / "s.sqlite"
    monkeypatch.setenv("PATHCHECK_STORE", str(store_path))
    with ResultsStore() as store:
        store.record_job(synthetic_document(1, n=11), elapsed_s=1.0)
    out = tmp_path / "r" / "night.html"
    with pytest.raises(SystemExit) as exit_info:
        main(["report", "--since", "2h", "--out", str(out), "--points-csv",
              str(tmp_path / "p.csv")])
    assert exit_info.value.code == 0
    said = capsys.readouterr().out
    assert "1 job, 5 pictures" in said and f"points: {tmp_path / 'p.csv'}" in said
    assert all(out.with_suffix(s).is_file() for s in (".html", ".json", ".csv"))
    assert len(list(csv.reader((tmp_path / "p.csv").open()))) == 1 + 11 * 11  # header, points
    with pytest.raises(SystemExit) as exit_info:
        main(["report", "--since", "yesterday", "--out", str(out)])
    assert exit_info.value.code == 2
    assert "--since" in capsys.readouterr().err


def test_painter_pictures_do_not_depend_on_the_jobs_before():
    docs = [synthetic_document(1, n=11), synthetic_document(2, n=11, four_axis=False),
            synthetic_document(3, n=11, cutter_r=3.0)]
    docs.append(docs[1])
    tasks = []
    for d in docs:
        std = standard_cutters(d.job.cutter_kind, d.job.cutter, d.job.cutter_size, (1.0,))
        tasks.append((point_arrays(d), std, d.job.cutter_size, "r"))
    shared = JobPainter()
    in_turn = [shared.render(*t)[0] for t in tasks]
    alone = [JobPainter().render(*t)[0] for t in tasks[:3]]
    assert in_turn[:3] == alone and in_turn[3] == alone[1]
