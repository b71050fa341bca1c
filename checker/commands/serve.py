"""`pathcheck serve`: run the ZeroMQ service (broker + worker processes) until SIGTERM/SIGINT,
which drain the requests in flight and exit 0."""

from __future__ import annotations

import logging
import signal
from pathlib import Path

import click

from checker.config import load_config


@click.command()
@click.option("--bind", default=None, help="front-end address [config: service.bind], "
              "e.g. tcp://127.0.0.1:5555 (port * picks a free one)")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="worker processes [config: service.workers]")
@click.option("--config", "config_file", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="TOML file overriding the shipped defaults")
@click.option("--store", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="results store to record every request in [config: store.path]")
@click.option("--no-store", is_flag=True, help="do not record requests")
def serve(bind: str | None, workers: int | None, config_file: Path | None, store: Path | None,
          no_store: bool) -> None:
    """Serve checks to CAM post-processors over ZeroMQ (protocol: docs/protocol.md).
    Logs one line per request on stderr."""
    from checker.service.broker import Broker

    config = load_config(config_file)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    store_path = None if no_store else str(store or config.store.resolved_path())
    broker = Broker(config, bind=bind, workers=workers, store=store_path)
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: broker.request_stop())
    broker.run()
