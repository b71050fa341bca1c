"""`pathcheck report [--since 24h] [-o report.html] [--points-csv FILE]`: the nightly page
over the results store, with a JSON and a CSV summary beside it, and a CSV of every point."""

from __future__ import annotations

from pathlib import Path

import click

from checker.commands import options as opt


@click.command()
@click.option("--since", default="24h", show_default=True,
              help="jobs recorded in this last period: 24h, 90m, 7d, 3600s")
@opt.output_option("the HTML page; .json and .csv summaries are written beside it",
                   hidden_names=("--out",), default=Path("report.html"))
@opt.store_option()
@opt.config_option(help="configuration TOML: the store is its store.path")
@click.option("--points-csv", "points_csv", default=None, metavar="FILE",
              type=click.Path(dir_okay=False, path_type=Path),
              help="also write every checked point of the jobs as CSV (part frame, mm, degrees)")
def report(since: str, output: Path, store_path: Path | None, config_path: Path | None,
           points_csv: Path | None) -> None:
    """Write one self-contained HTML page (no network needed to view it) of the jobs of the
    night: a table, per job the allowable- and standard-cutter maps, B along the path and where
    the findings are, and trends against previous nights.

    \b
    pathcheck report --since 24h -o report.html
    """
    from checker.commands.outputs import prepare_outputs
    from checker.config import default_config
    from checker.progress import step
    from checker.report import build_report, parse_since
    from checker.store import ResultsStore

    since_s = parse_since(since)
    store_file = opt.store_of(store_path, config_path)
    prepare_outputs([("-o", output, "HTML report"),
                     ("its JSON", output.with_suffix(".json"), "report JSON"),
                     ("its CSV", output.with_suffix(".csv"), "report CSV"),
                     ("--points-csv", points_csv, "points CSV")],
                    [("the results store", store_file if store_file is not None else
                      default_config().store.resolved_path()), ("--config", config_path)])
    with ResultsStore(store_file) as store, step("write the report"):
        files = build_report(store, output, since_s=since_s, points_csv=points_csv)
    what = {0: "no jobs", 1: "1 job"}.get(files.jobs, f"{files.jobs} jobs")
    skipped = (f"; {files.skipped} unreadable row{'s' if files.skipped > 1 else ''} skipped"
               if files.skipped else "")
    click.echo(f"{what}, {files.pictures} pictures: {files.html} ({files.json.name}, "
               f"{files.csv.name} beside it){skipped}")
    if files.points_csv is not None:
        click.echo(f"points: {files.points_csv}")
