"""The report's HTML page: one self-contained file (inline CSS, pictures as data: URIs, no script,
no network), built from the job summaries, the pictures and the trends. The markup is the
Jinja2 template `checker/resources/templates/report.html.j2` (autoescaped); this module gives
it the numbers as text."""

from __future__ import annotations

from functools import cache
from pathlib import PurePath

from jinja2 import Environment, FileSystemLoader, StrictUndefined, Template
from markupsafe import Markup, escape

from checker.report.pictures import CSS_PX_PER_IN, PANEL_IN, TREND_IN
from checker.report.trends import local_iso
from checker.resources import resource

DASH = Markup("&ndash;")  # a number that is not there


def _num(value: float | int | None, fmt: str = "{:.3f}") -> str:
    return DASH if value is None else fmt.format(value)


def _mm(value: float | None) -> str:
    """A length, mm: 3 decimals, or 2 significant digits when it is below 0.001 but not 0."""
    if value is not None and 0 < abs(value) < 1e-3:
        return _num(value, "{:.1e}")
    return _num(value)


def _breakable(path: str) -> Markup:
    """A path, escaped, that a narrow table cell may wrap after its slashes."""
    return escape(path).replace("/", Markup("/<wbr>"))


def _px(inches: float) -> int:
    """A picture's size in inches as CSS px (`CSS_PX_PER_IN`), whatever its dpi."""
    return round(inches * CSS_PX_PER_IN)


@cache
def _template() -> Template:
    env = Environment(
        loader=FileSystemLoader(resource("templates")),
        autoescape=True,
        undefined=StrictUndefined, trim_blocks=True, lstrip_blocks=True,
    )
    env.filters.update(num=_num, mm=_mm, breakable=_breakable, px=_px)
    return env.get_template("report.html.j2")


def _delta(job: dict) -> str:
    if job["previous_status"] is None:
        return "first run"
    if job["previous_gouges"] is None:
        return "previous run failed"
    d = job["gouge"] - job["previous_gouges"]
    return "same gouges" if d == 0 else f"{d:+d} gouges"


def _trend_cells(quantity: str, tonight, previous, mean) -> tuple[str, tuple[str, str, str]]:
    """A row of the trend table: the quantity and its three numbers as text."""
    if quantity == "worst depth":
        return quantity, (_mm(tonight), _mm(previous), _mm(mean))
    return quantity, (_num(tonight, "{:g}"), _num(previous, "{:g}"), _num(mean, "{:.2f}"))


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


def _shown(job: dict) -> dict:
    """The job with what the template shows of it beside its summary: the surfaces grouped by
    their largest safe cutter, the change since the previous run, the meta line and the
    pictures with their captions."""
    groups: dict[str, list[str]] = {}
    for surface, name in job["regions"]:
        groups.setdefault(name, []).append(f"S{surface}")
    meta = [f"{k}: {job[k]}" for k in ("recorded_at", "cutter", "part", "machine", "axis_class")
            if job[k]]
    figures = (list(zip(job["pictures"], _captions(job), strict=True)) if job["pictures"]
               else [])
    if job.get("deviation"):
        figures.append(job["deviation"])
    delta = _delta(job) if job["status"] != "failed" else ""
    return {**job, "region_groups": list(groups.items()), "delta": delta, "meta": meta,
            "figures": figures}


def render_page(
    jobs: list[dict], since: float, until: float, trend_png: str | None, trend_rows: list[tuple]
) -> str:
    """The whole page. `jobs` are the summaries of `build.job_summary` with `pictures` (base64
    PNG, four per job that did not fail) and `facts` (see `JobPainter.render`); times are UTC
    epoch seconds, shown as ISO 8601 local time."""
    return _template().render(
        jobs=[_shown(j) for j in jobs],
        counts={s: sum(j["status"] == s for j in jobs) for s in ("ok", "findings", "failed")},
        since=local_iso(since), until=local_iso(until), trend_png=trend_png,
        trend_rows=[_trend_cells(*row) for row in trend_rows],
        panel_in=PANEL_IN, trend_in=TREND_IN,
    )
