"""The command line: `pathcheck JOB.apt` and its subcommands. Thin: parse, call the library,
format. Subcommands live in `checker.commands.*` and are imported only when used, so that
`pathcheck info` does not pay for numba or OpenCASCADE."""

from __future__ import annotations

import importlib
import signal
import sys

import click

from checker.errors import PathcheckError

# subcommand name -> "module:attribute" of its click command
SUBCOMMANDS: dict[str, str] = {
    "check": "checker.commands.check:check",
    "info": "checker.commands.info:info",
    "allowable": "checker.commands.allowable:allowable",
    "map": "checker.commands.map:map_command",
    "check-gcode": "checker.commands.check_gcode:check_gcode",
    "serve": "checker.commands.serve:serve",
    "call": "checker.commands.call:call",
    "batch": "checker.commands.batch:batch",
    "report": "checker.commands.report:report",
    "warm": "checker.commands.warm:warm",
}


class JobGroup(click.Group):
    """A group whose unknown first word is a job file: `pathcheck job.apt` = `pathcheck check
    job.apt`. Subcommands are loaded lazily from SUBCOMMANDS."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(SUBCOMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        target = SUBCOMMANDS.get(cmd_name)
        if target is None:
            return None
        module_name, attr = target.split(":")
        return getattr(importlib.import_module(module_name), attr)

    def resolve_command(self, ctx: click.Context, args: list[str]):
        if args and args[0] not in SUBCOMMANDS and not args[0].startswith("-"):
            return "check", self.get_command(ctx, "check"), args
        return super().resolve_command(ctx, args)


@click.group(cls=JobGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="pathcheck")
def cli() -> None:
    """pathcheck: check a CNC tool path for gouges and interference, find the largest safe
    cutter and the best table angle B, and post corrected 4-axis G-code.

    \b
    pathcheck JOB.apt [--part PART] [--json OUT] [-o JOB.nc]   check a job
    pathcheck info FILE [--json]                               what is in a CL or part file
    """


def _terminated(signum: int, frame: object) -> None:
    """SIGTERM ends the run like an interrupt: files being written are removed, not left
    half-written (`checker.atomic`); exit code 128 + the signal number."""
    raise SystemExit(128 + signum)


def main(argv: list[str] | None = None) -> None:
    """Console entry point: bad input is one line on stderr and exit code 2, never a traceback."""
    signal.signal(signal.SIGTERM, _terminated)
    try:
        cli.main(args=argv, prog_name="pathcheck", standalone_mode=False)
    except PathcheckError as err:
        click.echo(f"pathcheck: {err}", err=True)
        sys.exit(2)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(2)
    except click.exceptions.Abort:
        click.echo("pathcheck: aborted", err=True)
        sys.exit(2)
    except KeyboardInterrupt:
        sys.exit(130)
    sys.exit(0)


if __name__ == "__main__":
    main()
