"""`pathcheck batch DIR_OR_GLOB [--workers N] [--scheduler ADDRESS]`: check many jobs with a
progress bar, on this machine (process pool) or on an existing Dask cluster; every outcome is
recorded in the results store. Exit 0 when every job is clean, 1 when any has findings or
failed."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import click

from checker.commands import options as opt


@click.command()
@click.argument("jobs", metavar="DIR_OR_GLOB")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="processes on this machine [default: the number of CPUs]")
@click.option("--scheduler", default=None, metavar="ADDRESS", envvar="DASK_SCHEDULER_ADDRESS",
              show_envvar=True,
              help="run the jobs on this Dask distributed scheduler (tcp://host:8786)")
@opt.store_option()
@opt.config_option(help="configuration TOML: the store is its store.path")
@click.option("--job-function", default="checker.check:check_job", hidden=True,
              help="module:function that checks one job (tests and benchmarks)")
def batch(jobs: str, workers: int | None, scheduler: str | None, store_path: Path | None,
          config_path: Path | None, job_function: str) -> None:
    """Check every CL file (APT-CL or NX CLSF, known by content) of a directory (recursively)
    or of a glob pattern; on a Dask cluster with --scheduler or DASK_SCHEDULER_ADDRESS.

    \b
    pathcheck batch samples/ --workers 2
    pathcheck batch 'night/**/*.apt' --scheduler tcp://cluster:8786
    """
    from checker.batch import find_jobs, run_batch
    from checker.progress import step
    from checker.store import ResultsStore, job_status

    paths = find_jobs(jobs)
    if scheduler is not None:
        from checker.extras import require

        require("distributed", "dask", "running jobs on a Dask cluster")
    counts = {"ok": 0, "findings": 0, "failed": 0}
    unrecorded: list[str] = []
    with ResultsStore(opt.store_of(store_path, config_path)) as store, \
            step(f"checking {len(paths)} jobs", total=len(paths)) as advance:

        def done(outcome) -> None:
            doc = outcome.results()
            counts["failed" if doc is None else job_status(doc)] += 1
            advance(1)
            if outcome.error:
                click.echo(f"failed {outcome.error}", err=True)
            if outcome.unrecorded:
                unrecorded.append(outcome.path)
                click.echo(f"not recorded {outcome.unrecorded}", err=True)

        run_batch(paths, store=store, workers=workers or os.cpu_count() or 1,
                  scheduler=scheduler, job_function=job_function, on_result=done)
        where = store.path
    missing = f" ({len(unrecorded)} could not be recorded)" if unrecorded else ""
    click.echo(
        f"{len(paths)} jobs: {counts['ok']} clean, {counts['findings']} with findings, "
        f"{counts['failed']} failed; recorded in {where}{missing}"
    )
    sys.exit(0 if counts["ok"] == len(paths) else 1)
