"""`pathcheck serve`: run the ZeroMQ service (broker + worker processes) until SIGTERM/SIGINT,
which drain the requests in flight and exit 0. `pathcheck serve --new-keys DIR` writes CURVE
keys for `--curve-keys DIR` and exits."""

from __future__ import annotations

import logging
import signal
from pathlib import Path

import click

from checker.commands import options as opt
from checker.config import load_config


@click.command()
@click.option("--bind", default=None, help="front-end address [config: service.bind], "
              "e.g. tcp://127.0.0.1:5555 (port * picks a free one)")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="worker processes [config: service.workers]")
@click.option("--root", "roots", multiple=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="folder whose files requests may name (repeatable) [the working directory]")
@click.option("--curve-keys", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="CURVE key folder: encrypt and admit only the clients in DIR/clients/")
@click.option("--insecure", is_flag=True,
              help="allow a bind beyond loopback without --curve-keys")
@click.option("--new-keys", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="write a server and a client key pair into this folder and exit")
@opt.config_option()
@opt.store_option(help="results store to record every request in [config: store.path]")
@click.option("--no-store", is_flag=True, help="do not record requests")
@click.option("--keep-days", type=click.FloatRange(min=0), default=None,
              help="retention: delete stored checks and requests older than this, at start "
              "and hourly (as `pathcheck store prune --keep-days`)")
def serve(bind: str | None, workers: int | None, roots: tuple[Path, ...],
          curve_keys: Path | None, insecure: bool, new_keys: Path | None,
          config_path: Path | None, store_path: Path | None, no_store: bool,
          keep_days: float | None) -> None:
    """Serve checks to CAM post-processors over ZeroMQ (protocol: docs/protocol.md).
    Logs one line per request on stderr.

    \b
    pathcheck serve --root /srv/cam                      # on 127.0.0.1:5555
    pathcheck serve --new-keys keys/                     # once: CURVE keys
    pathcheck serve --bind tcp://0.0.0.0:5555 --curve-keys keys/ --root /srv/cam
    """
    if new_keys is not None:
        from checker.service.keys import new_keys as write_keys

        for path in write_keys(new_keys):
            click.echo(path)
        return
    from checker.service.broker import Broker, check_bind
    from checker.service.roots import Roots

    config = load_config(config_path)
    check_bind(bind or config.service.bind, curve=curve_keys is not None, insecure=insecure)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    store = None if no_store else str(store_path or config.store.resolved_path())
    broker = Broker(config, bind=bind, workers=workers, store=store, roots=Roots(roots),
                    curve_keys=curve_keys, insecure=insecure, keep_days=keep_days)
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: broker.request_stop())
    broker.run()
