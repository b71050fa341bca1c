"""`pathcheck store prune --keep-days N --keep N [--vacuum]`: the results store's retention.
Every check is recorded with its whole document (about 1 MB for a large job), so a shop
prunes the store on a schedule (e.g. nightly after the report)."""

from __future__ import annotations

from pathlib import Path

import click

from checker.commands import options as opt


@click.group()
def store() -> None:
    """Maintain the results store (PATHCHECK_STORE or config store.path)."""


@store.command()
@click.option("--keep-days", type=float, default=None, metavar="DAYS",
              help="delete jobs and service requests recorded more than DAYS days ago")
@click.option("--keep", type=click.IntRange(min=0), default=None, metavar="N",
              help="keep only the newest N records of each job path")
@click.option("--vacuum", is_flag=True,
              help="then give the freed space back to the file system (rewrites the file)")
@opt.store_option()
@opt.config_option(help="configuration TOML: the store is its store.path")
def prune(keep_days: float | None, keep: int | None, vacuum: bool, store_path: Path | None,
          config_path: Path | None) -> None:
    """Delete old records: older than --keep-days, beyond the newest --keep per job (give one
    or both).

    \b
    pathcheck store prune --keep-days 90
    pathcheck store prune --keep 30 --vacuum
    """
    from checker.store import prune as prune_store

    done = prune_store(opt.store_of(store_path, config_path), keep_days=keep_days, keep=keep,
                       vacuum=vacuum)
    click.echo(f"deleted {done.jobs} jobs and {done.requests} service requests; "
               f"{done.remaining} jobs kept")
