"""The report's HTML page: one self-contained file (inline CSS, pictures as data: URIs, no script,
no network), built from the job summaries, the pictures and the trends."""

from __future__ import annotations

from html import escape
from pathlib import PurePath

from checker.report.pictures import CSS_PX_PER_IN, PANEL_IN, TREND_IN
from checker.report.trends import local_iso

CSS = """
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222;background:#fff}
h1{margin:0 0 .2em}h2{margin-top:1.5em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.5em 0}th,td{border:1px solid #ccc;padding:2px 7px}
th{background:#f0f0f0;text-align:left}td.n{text-align:right;font-variant-numeric:tabular-nums}
tr.failed td{background:#fde2e2}tr.findings td.status{background:#ffe9c7;font-weight:bold}
tr.ok td.status{background:#dff3df}.empty{font-size:1.3em;padding:1em;background:#f6f6f6}
.job{margin:1em 0 2em}.pics{display:flex;flex-wrap:wrap;gap:12px}
figure{margin:0;width:min-content}figcaption{font-size:13px;color:#444}.meta{color:#555;font-size:13px}
"""


def _num(value: float | int | None, fmt: str = "{:.3f}") -> str:
    return "&ndash;" if value is None else escape(fmt.format(value))


def _mm(value: float | None) -> str:
    """A length, mm: 3 decimals, or 2 significant digits when it is below 0.001 but not 0."""
    if value is not None and 0 < abs(value) < 1e-3:
        return _num(value, "{:.1e}")
    return _num(value)


def _regions(job: dict) -> str:
    """'BALL-D8: S0, S2 · none: S3': the surfaces grouped by their largest safe cutter."""
    groups: dict[str, list[str]] = {}
    for surface, name in job["regions"]:
        groups.setdefault(name, []).append(f"S{surface}")
    text = " &middot; ".join(f"{escape(n)}: {', '.join(s)}" for n, s in groups.items())
    std = job["largest_safe_standard"]
    return text or (escape(std) if std else "&ndash;")


def _breakable(path: str) -> str:
    """A path, escaped, that a narrow table cell may wrap after its slashes."""
    return escape(path).replace("/", "/<wbr>")


def _img(b64: str, alt: str, inches: tuple[float, float] = PANEL_IN) -> str:
    """A picture shown at its size in inches (`CSS_PX_PER_IN`), whatever its dpi."""
    w, h = (round(x * CSS_PX_PER_IN) for x in inches)
    return (f'<img class="pic" width="{w}" height="{h}" alt="{escape(alt)}" '
            f'src="data:image/png;base64,{b64}">')


def _job_table(jobs: list[dict]) -> str:
    head = (
        "<tr><th>#</th><th>job</th><th>status</th><th>points</th><th>gouges</th>"
        "<th>interferences</th><th>holder hits</th><th>crashes</th><th>inaccessible</th>"
        "<th>worst depth, mm</th>"
        "<th>worst margin, mm</th><th>largest safe standard cutter per region</th>"
        "<th>vs previous run</th><th>time, s</th></tr>"
    )
    rows = []
    for j in jobs:
        if j["status"] == "failed":
            detail = f'<td colspan="10">failed: {escape(j["error"] or "")}</td>'
        else:
            detail = (
                f'<td class="n">{j["points"]}</td><td class="n">{j["gouge"]}</td>'
                f'<td class="n">{j["interference"]}</td><td class="n">{j["holder"]}</td>'
                f'<td class="n">{j["crash"]}</td><td class="n">{j["inaccessible"]}</td>'
                f'<td class="n">{_mm(j["worst_depth"])}</td>'
                f'<td class="n">{_mm(j["worst_margin"])}</td><td>{_regions(j)}</td>'
                f'<td class="n">{_delta(j)}</td>'
            )
        rows.append(
            f'<tr class="job {j["status"]}" id="row-{j["id"]}"><td class="n">{j["id"]}</td>'
            f'<td><a href="#job-{j["id"]}">{_breakable(j["job_path"])}</a></td>'
            f'<td class="status">{j["status"]}</td>{detail}'
            f'<td class="n">{_num(j["elapsed_s"], "{:.2f}")}</td></tr>'
        )
    return f'<table class="jobs">{head}{"".join(rows)}</table>'


def _delta(job: dict) -> str:
    if job["previous_status"] is None:
        return "first run"
    if job["previous_gouges"] is None:
        return "previous run failed"
    d = job["gouge"] - job["previous_gouges"]
    return "same gouges" if d == 0 else f"{d:+d} gouges"


def _trend_table(rows: list[tuple]) -> str:
    head = (
        "<tr><th></th><th>tonight</th><th>previous night</th>"
        "<th>mean of earlier nights</th></tr>"
    )
    body = []
    for quantity, tonight, previous, mean in rows:
        if quantity == "worst depth":
            cells = (_mm(tonight), _mm(previous), _mm(mean))
        else:
            cells = (_num(tonight, "{:g}"), _num(previous, "{:g}"), _num(mean, "{:.2f}"))
        tds = "".join(f'<td class="n">{c}</td>' for c in cells)
        body.append(f"<tr><th>{escape(quantity)}</th>{tds}</tr>")
    return f'<table class="trend">{head}{"".join(body)}</table>'


def findings_caption(job: dict) -> str:
    """'68 findings highlighted: 62 gouge, 6 interference, 0 holder hit, 0 crash': from the
    job's counts, the numbers of its row in the table (poses and moves of the written
    program)."""
    n = {k: job[k] or 0 for k in ("gouge", "interference", "holder", "crash")}
    return (f"{sum(n.values())} findings highlighted: {n['gouge']} gouge, "
            f"{n['interference']} interference, {n['holder']} holder hit, {n['crash']} crash")


def _captions(job: dict) -> tuple[str, ...]:
    f = job["facts"]
    part = PurePath(job["part"]).name if job["part"] else "the part"
    what = f"{job['cutter'] or job['cutter_kind'] or 'the cutter'} on {part}"
    view = f"{f['view']} view, {f['extent'][0]:.0f} x {f['extent'][1]:.0f} mm"
    least = job["largest_safe_cutter"]
    least = "unbounded" if least is None else f"{least:.3g} mm"
    size = f"allowable {f['symbol']}"
    return (
        f"Allowable cutter, {what} ({view}): colour = {size} at each CC point, mm, log scale; "
        f"pink = unbounded; smallest {least}",
        f"Standard cutter, {what} ({view}): the largest standard cutter of the family that "
        f"fits at each CC point ({size} in mm)",
        f"Findings on {part} ({view}): {findings_caption(job)}",
        "B chosen against best B along the path" if f["has_b"]
        else f"{size} along the path (log scale, mm) against the real cutter (dashed); "
        "pink at the top: unbounded",
    )


def _job_section(job: dict) -> str:
    captions = _captions(job)
    figs = "".join(
        f"<figure>{_img(b64, cap)}<figcaption>{escape(cap)}</figcaption></figure>"
        for b64, cap in zip(job["pictures"], captions, strict=True)
    )
    meta = " &middot; ".join(
        escape(f"{k}: {job[k]}") for k in ("recorded_at", "cutter", "part", "machine", "axis_class")
        if job[k]
    )
    return (
        f'<section class="job" id="job-{job["id"]}"><h3>#{job["id"]} '
        f'{escape(job["job_path"])} &mdash; {job["status"]}</h3>'
        f'<div class="meta">{meta}</div><div class="pics">{figs}</div></section>'
    )


def render_page(
    jobs: list[dict], since: float, until: float, trend_png: str | None, trend_rows: list[tuple]
) -> str:
    """The whole page. `jobs` are the summaries of `build.job_summary` with `pictures` (base64
    PNG, four per job that did not fail) and `facts` (see `JobPainter.render`); times are UTC
    epoch seconds, shown as ISO 8601 local time."""
    counts = {s: sum(j["status"] == s for j in jobs) for s in ("ok", "findings", "failed")}
    parts = [
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">",
        f"<title>pathcheck report {local_iso(until)}</title><style>{CSS}</style></head><body>",
        "<h1>pathcheck nightly report</h1>",
        f'<p class="meta">jobs recorded from {local_iso(since)} to {local_iso(until)}</p>',
    ]
    if not jobs:
        parts.append(
            f'<p class="empty" id="no-jobs">No jobs were recorded between {local_iso(since)} and '
            f"{local_iso(until)}.</p>"
        )
    else:
        parts.append(
            f'<p class="totals"><b>{len(jobs)}</b> jobs: <b>{counts["ok"]}</b> clean, '
            f'<b>{counts["findings"]}</b> with findings, <b>{counts["failed"]}</b> failed.</p>'
        )
    parts.append("<h2>Trends against previous nights</h2>")
    if trend_png:
        parts.append(_img(trend_png, "jobs and gouge points per night", TREND_IN))
    parts.append(_trend_table(trend_rows))
    if jobs:
        parts += ["<h2>Jobs</h2>", _job_table(jobs), "<h2>Pictures per job</h2>"]
        parts += [_job_section(j) for j in jobs if j["pictures"]]
    parts.append("</body></html>")
    return "\n".join(parts)
