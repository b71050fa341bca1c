"""Build the nightly report from the results store: the HTML page, and beside it (same stem) a
JSON and a CSV summary for other systems, and when asked a CSV of every checked point. Pictures
of many jobs are drawn in a few processes."""

from __future__ import annotations

import csv
import io
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from checker.atomic import write_file
from checker.config import Config, default_config
from checker.cutter import size_symbol_of
from checker.errors import PathcheckError
from checker.report.page import render_page
from checker.report.pictures import JobPainter, trend_picture
from checker.report.standard import per_region, standard_cutters
from checker.report.trends import DAY_S, compare, local_iso, nights
from checker.results import VERDICTS
from checker.store import JobRow, ResultsStore

PARALLEL_FROM = 8  # jobs; fewer are drawn in this process (starting workers costs more)
CSV_COLUMNS = (
    "id", "recorded_at", "job_path", "status", "error", "points", "ok", "gouge", "interference",
    "holder", "crash", "inaccessible", "worst_margin", "worst_depth", "largest_safe_cutter",
    "largest_safe_standard", "regions", "previous_status", "previous_gouges", "elapsed_s",
    "cutter", "cutter_kind", "part", "part_hash", "machine", "axis_class", "stock",
    "rest_machining",
)
POINT_COLUMNS = (  # the per-point CSV: part frame, mm, degrees; empty = null
    "job_id", "job_path", "recorded_at", "index", "operation", "line", "kind", "rapid", "x", "y",
    "z", "verdict", "depth", "tolerance", "allowable", "margin", "b", "b_best",
)


@dataclass(frozen=True)
class ReportFiles:
    """What `build_report` wrote: the page, the JSON and CSV summaries, how many jobs and
    pictures the page holds, and the per-point CSV when asked."""

    html: Path
    json: Path
    csv: Path
    jobs: int
    pictures: int
    skipped: int = 0  # rows of the store that could not be read (left out)
    points_csv: Path | None = None


# per process: the open store, the painter and the standard diameters (see _painter_setup)
_STATE: tuple[ResultsStore, JobPainter, tuple[float, ...]] | None = None


def _painter_setup(store_path: str, diameters: tuple[float, ...], dpi: int) -> None:
    """Open the store and make the painter of this process."""
    global _STATE
    _STATE = (ResultsStore(store_path), JobPainter(dpi), diameters)


def _draw(task: tuple) -> tuple[int, list[str], dict, list]:
    """Pictures, their facts and the per-region standard cutters of one job (runs in a worker
    or in this process)."""
    job_id, kind, cutter, cutter_size = task
    store, painter, diameters = _STATE
    try:
        arrays = store.arrays(job_id)
    except PathcheckError:  # a damaged row: skipped and counted, the report goes on
        return job_id, None, None, None
    if arrays is None:  # recorded before the store kept per-point arrays
        return job_id, [], None, []
    standard = standard_cutters(kind, cutter, cutter_size, diameters)
    reach = arrays["kind"] & (arrays["verdict"] != VERDICTS.index("inaccessible"))
    regions = per_region(standard, arrays["allowable"][reach], arrays["surface"][reach])
    return job_id, *painter.render(arrays, standard, cutter_size, size_symbol_of(kind)), regions


def _draw_all(store: ResultsStore, rows: list[JobRow], cfg: Config) -> dict[int, tuple]:
    """job id -> (pictures, facts, regions) of every job that did not fail; in this process for
    a few jobs, else in `report.render_workers` processes."""
    tasks = [(r.id, r.cutter_kind, r.cutter, r.cutter_size) for r in rows if r.status != "failed"]
    setup = (str(store.path), cfg.report.standard_diameters, cfg.report.picture_dpi)
    workers = min(cfg.report.render_workers, os.cpu_count() or 1, len(tasks))
    if len(tasks) < PARALLEL_FROM or workers < 2:
        _painter_setup(*setup)
        try:
            return {t[0]: _draw(t)[1:] for t in tasks}
        finally:
            _STATE[0].close()
    with ProcessPoolExecutor(workers, initializer=_painter_setup, initargs=setup) as pool:
        chunk = max(1, len(tasks) // (4 * workers))
        return {job_id: rest for job_id, *rest in pool.map(_draw, tasks, chunksize=chunk)}


def job_summary(row: JobRow, previous: JobRow | None) -> dict:
    """The row of one job in the table, JSON and CSV (mm, s; recorded_at ISO 8601 local)."""
    return {
        "id": row.id, "recorded_at": local_iso(row.recorded_at), "job_path": row.job_path,
        "status": row.status, "error": row.error, "points": row.points, "ok": row.n_ok,
        "gouge": row.n_gouge, "interference": row.n_interference, "holder": row.n_holder,
        "crash": row.n_crash, "inaccessible": row.n_inaccessible, "worst_margin": row.worst_margin,
        "worst_depth": row.worst_depth, "largest_safe_cutter": row.largest_safe_cutter,
        "largest_safe_standard": row.largest_safe_standard, "regions": [],
        "previous_status": None if previous is None else previous.status,
        "previous_gouges": None if previous is None else previous.n_gouge,
        "elapsed_s": row.elapsed_s, "cutter": row.cutter, "cutter_kind": row.cutter_kind,
        "part": row.part,
        "part_hash": row.part_hash, "machine": row.machine, "axis_class": row.axis_class,
        "stock": row.stock,
    }


def view_beside(report: Path, job_path: str | None) -> str | None:
    """The job's 3-D view when one was written beside the report as `JOB.view.html` (JOB the
    job file's stem; `pathcheck check JOB.apt --view DIR/JOB.view.html`): its name, to link."""
    if not job_path:
        return None
    name = f"{Path(job_path).stem}.view.html"
    return name if (report.parent / name).is_file() else None


def parse_since(text: str) -> float:
    """'24h', '90m', '7d', '3600s' or a bare number of hours -> seconds."""
    units = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": DAY_S}
    t = text.strip().lower()
    scale = units.get(t[-1:])
    try:
        value = float(t[:-1] if scale else t) * (scale or 3600.0)
    except ValueError:
        value = -1.0
    if not value > 0:
        raise PathcheckError(
            f"--since: expected a positive duration like 24h, 90m or 7d, found '{text}'",
            code="usage",
        )
    return value


def build_report(
    store: ResultsStore, out: str | Path, *, since_s: float = DAY_S, now: float | None = None,
    config: Config | None = None, points_csv: str | Path | None = None,
) -> ReportFiles:
    """Write the page `out` and `out` with .json and .csv suffixes, over the jobs recorded in
    the last `since_s` seconds before `now` (UTC epoch s, default: the present); and the
    per-point CSV `points_csv` when given (one row per checked point of those jobs)."""
    cfg = config or default_config()
    until = time.time() if now is None else now
    since = until - since_s
    out = Path(out)
    history = store.jobs(since=until - cfg.report.trend_nights * DAY_S, until=until)
    rows = store.jobs(since=since, until=until)
    drawn = _draw_all(store, rows, cfg)
    unreadable = {job_id for job_id, (pictures, *_) in drawn.items() if pictures is None}
    rows = [r for r in rows if r.id not in unreadable]
    jobs = [job_summary(r, store.previous(r.job_path, r.recorded_at)) for r in rows]
    for j in jobs:
        j["pictures"], j["facts"], j["regions"] = drawn.get(j["id"], ([], None, []))
        j["view"] = view_beside(out, j["job_path"])
        j["rest_machining"], j["deviation"] = _machined(store, j) if j["stock"] else (None, None)
    per_night = nights(history, until, cfg.report.trend_nights)
    trend_png = trend_picture(per_night, cfg.report.picture_dpi) if history else None
    html = render_page(jobs, since, until, trend_png, compare(per_night))
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_file(out, html, what="report page")
        _write_json(out.with_suffix(".json"), jobs, since, until, per_night, len(unreadable))
        _write_csv(out.with_suffix(".csv"), jobs)
        if points_csv is not None:
            _write_points(Path(points_csv), store, jobs)
    except OSError as err:
        raise PathcheckError(f"cannot write the report: {err.strerror}",
                             path=err.filename or out, code="report") from err
    pictures = sum(len(j["pictures"]) for j in jobs) + (trend_png is not None)
    return ReportFiles(out, out.with_suffix(".json"), out.with_suffix(".csv"), len(jobs), pictures,
                       len(unreadable), None if points_csv is None else Path(points_csv))


def _machined(store: ResultsStore, job: dict) -> tuple[str | None, tuple[str, str] | None]:
    """(the rest-machining advice, (the deviation map as base64 PNG, its caption)) of a job
    checked against a stock with a part (`stock.machined`: docs/MATH.md §15); the map when
    its file (`--deviation-out`) is still there."""
    import base64

    try:
        doc = store.document(job["id"])
    except (PathcheckError, ValueError):
        return None, None
    m = None if doc is None or doc.stock is None else doc.stock.machined
    if m is None:
        return None, None
    picture = Path(m.picture) if m.picture else None
    if picture is None or not picture.is_file():
        return m.advice, None
    caption = (f"The machined part against the design (top view): over-cut up to "
               f"{m.overcut_max:.3g} mm ({m.overcut_regions} regions beyond the tolerance), "
               f"material left up to {m.left_max:.3g} mm; {m.advice or 'no rest machining'}")
    return m.advice, (base64.b64encode(picture.read_bytes()).decode("ascii"), caption)


def _plain(job: dict) -> dict:
    return {k: v for k, v in job.items() if k not in ("pictures", "facts", "deviation")}


def _write_json(path: Path, jobs: list[dict], since: float, until: float, per_night: list,
                skipped: int) -> None:
    doc = {
        "tool": "pathcheck", "kind": "report", "since": local_iso(since),
        "until": local_iso(until), "skipped_unreadable": skipped,
        "totals": {s: sum(j["status"] == s for j in jobs) for s in ("ok", "findings", "failed")},
        "jobs": [_plain(j) for j in jobs],
        "nights": [{**n, "start": local_iso(n["start"])} for n in per_night],
    }
    write_file(path, json.dumps(doc, indent=1), what="report JSON")


def _write_csv(path: Path, jobs: list[dict]) -> None:
    text = io.StringIO(newline="")
    writer = csv.DictWriter(text, fieldnames=CSV_COLUMNS)
    writer.writeheader()
    for j in jobs:
        row = _plain(j)
        row.pop("view", None)
        row["regions"] = " ".join(f"S{s}:{n}" for s, n in j["regions"])
        writer.writerow(row)
    write_file(path, text.getvalue(), what="report CSV")


def _write_points(path: Path, store: ResultsStore, jobs: list[dict]) -> None:
    """One row per checked point of every job that did not fail, from its stored document."""
    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(POINT_COLUMNS)
    for j in jobs:
        doc = store.document(j["id"]) if j["status"] != "failed" else None
        for p in doc.points if doc is not None else ():
            writer.writerow((
                j["id"], j["job_path"], j["recorded_at"], p.index, p.op, p.line, p.kind,
                int(p.rapid), *p.tip, p.verdict, *("" if v is None else v for v in (
                    p.depth, p.tolerance, p.allowable, p.margin, p.b, p.b_best)),
            ))
    write_file(path, text.getvalue(), what="report points CSV")
