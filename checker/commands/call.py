"""`pathcheck call OP [FIELD=VALUE ...]`: send one request to the service and print the reply
JSON, for scripts. An error reply is one line on stderr and exit code 2."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from checker.atomic import write_file
from checker.commands import options as opt
from checker.errors import PathcheckError, printable


@click.command()
@click.argument("op")
@click.argument("fields", nargs=-1)
@click.option("--address", default=None, help="service address [config: service.bind]")
@click.option("--timeout", "timeout_s", type=click.FloatRange(min=0, min_open=True),
              default=None, help="seconds to wait for each attempt [10 for ping and stats, "
              "600 for allowable and check]")
@click.option("--retries", type=click.IntRange(min=0), default=2, show_default=True)
@click.option("--dealer", is_flag=True, help="use a DEALER socket instead of REQ")
@click.option("--curve-keys", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="CURVE key folder (server.key, client.key_secret) for a service started "
              "with --curve-keys")
@click.option("--request", "request_file", type=click.File("r"), default=None,
              help="JSON object with the request fields ('-' reads stdin); FIELD=VALUE override")
@click.option("--cc", "cc_csv", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="CSV with a header row and columns x,y,z,nx,ny,nz: the `cc` field")
@opt.output_option("write the reply JSON here instead of stdout", hidden_names=("--out",))
@opt.config_option(help="configuration TOML: the address is its service.bind")
@click.option("--gcode-out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="write the reply's `gcode` (check with post=true) to this file")
def call(op: str, fields: tuple[str, ...], address: str | None, timeout_s: float | None,
         retries: int, dealer: bool, curve_keys: Path | None, request_file: Any,
         cc_csv: Path | None, output: Path | None, config_path: Path | None,
         gcode_out: Path | None) -> None:
    """Call the pathcheck service: OP is ping, stats, allowable or check; each FIELD=VALUE sets
    a request field (VALUE is JSON, else a string; @FILE reads the file's text; dotted names
    nest: part.path=part.json).

    \b
    pathcheck call ping
    pathcheck call allowable part.path=mould.json --cc cc.csv cutter=CUTTER/10,2
    pathcheck call check apt=@job.apt part.path=job.json post=true --gcode-out job.nc
    """
    from checker.cc_csv import cc_rows
    from checker.client import Client, raise_for_error
    from checker.commands.outputs import prepare_outputs
    from checker.config import load_config
    from checker.progress import step

    prepare_outputs([("-o", output, "reply JSON"), ("--gcode-out", gcode_out, "G-code")],
                    [("--cc", cc_csv), ("--config", config_path),
                     ("--request", None if request_file is None else
                      Path(getattr(request_file, "name", "-")))])
    message: dict[str, Any] = {}
    if request_file is not None:
        message = _json_object(request_file.read(), request_file.name)
    for item in fields:
        _set(message, *_field(item))
    if cc_csv is not None:
        message["cc"] = cc_rows(cc_csv)
    message["op"] = op
    if timeout_s is None:
        timeout_s = 10.0 if op in ("ping", "stats") else 600.0
    address = address or load_config(config_path).service.bind
    with Client(address, timeout_s=timeout_s, retries=retries,
                kind="dealer" if dealer else "req", curve_keys=curve_keys) as client, \
            step(f"{op}: waiting for the service"):
        reply = raise_for_error(client.call(**message))
    refused = gcode_out is not None and reply.get("refused")
    if gcode_out is not None and not refused:
        if not reply.get("gcode"):
            raise PathcheckError("the reply has no G-code (ask with post=true)", code="usage")
        write_file(gcode_out, reply["gcode"], what="G-code")
    text = json.dumps(reply, indent=1)
    if output is not None:
        write_file(output, text + "\n", what="reply JSON")
    else:
        click.echo(text)
    if refused:  # as `pathcheck check -o` does: nothing written, exit 1 (findings)
        click.echo(f"pathcheck: {printable(str(gcode_out))}: not written: {refused}; send "
                   "on_findings=stop or comment to write it", err=True)
        sys.exit(1)


def _json_object(text: str, name: str) -> dict:
    try:
        data = json.loads(text)
    except ValueError as err:
        raise PathcheckError(f"expected a JSON object, found invalid JSON: {err}", path=name,
                             code="usage") from err
    if not isinstance(data, dict):
        raise PathcheckError(f"expected a JSON object, found {type(data).__name__}", path=name,
                             code="usage")
    return data


def _field(item: str) -> tuple[list[str], Any]:
    """`a.b=VALUE` -> (['a', 'b'], value): JSON if it parses, @FILE the file's text, else text."""
    name, sep, raw = item.partition("=")
    if not sep or not name:
        raise PathcheckError(f"expected FIELD=VALUE, found {item!r}", code="usage")
    if raw.startswith("@"):
        try:
            return name.split("."), Path(raw[1:]).read_text()
        except OSError as err:
            raise PathcheckError(f"cannot read {name}: {err.strerror}", path=raw[1:],
                                 code="usage") from err
    try:
        return name.split("."), json.loads(raw)
    except ValueError:
        return name.split("."), raw


def _set(message: dict, keys: list[str], value: Any) -> None:
    for key in keys[:-1]:
        message = message.setdefault(key, {})
        if not isinstance(message, dict):
            raise PathcheckError(f"field '{key}' is not an object", code="usage")
    message[keys[-1]] = value
