"""The command line: `pathcheck JOB.apt` and its subcommands. Thin: parse, call the library,
format. Subcommands live in `checker.commands.*` and are imported only when used, so that
`pathcheck info` does not pay for numba or OpenCASCADE."""

from __future__ import annotations

import importlib
import signal
import sys

import click

from checker.commands.options import EXIT_CODES
from checker.commands.terminal import show_notes
from checker.errors import PathcheckError, printable

# subcommand name -> "module:attribute" of its click command
SUBCOMMANDS: dict[str, str] = {
    "check": "checker.commands.check:check",
    "info": "checker.commands.info:info",
    "allowable": "checker.commands.allowable:allowable",
    "map": "checker.commands.map:map_command",
    "flank": "checker.commands.flank:flank",
    "check-gcode": "checker.commands.check_gcode:check_gcode",
    "serve": "checker.commands.serve:serve",
    "call": "checker.commands.call:call",
    "batch": "checker.commands.batch:batch",
    "report": "checker.commands.report:report",
    "warm": "checker.commands.warm:warm",
    "store": "checker.commands.store:store",
    "view": "checker.commands.view:view",
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
        return _shared(getattr(importlib.import_module(module_name), attr))

    def resolve_command(self, ctx: click.Context, args: list[str]):
        if args and args[0] not in SUBCOMMANDS and not args[0].startswith("-"):
            return "check", self.get_command(ctx, "check"), args
        return super().resolve_command(ctx, args)


def _view(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    """Install the terminal view of `checker.progress` for this command (once) and set
    --quiet / --verbose on it."""
    from checker.commands.terminal import TerminalView
    from checker.progress import watching

    view = ctx.meta.get("pathcheck.view")
    if view is None:
        view = ctx.meta["pathcheck.view"] = TerminalView()
        ctx.with_resource(watching(view))
        ctx.call_on_close(view.close)
    if value:
        setattr(view, param.name, True)
    if view.quiet and view.verbose:
        raise click.UsageError("give --quiet or --verbose, not both")


_VERBOSITY = (
    click.Option(["-q", "--quiet"], is_flag=True, expose_value=False, callback=_view,
                 help="no progress display"),
    click.Option(["-v", "--verbose"], is_flag=True, expose_value=False, callback=_view,
                 help="print each step with its time (stderr)"),
)


def _shared(command: click.Command) -> click.Command:
    """Every command (and a group's subcommands) takes --quiet and --verbose and ends its help
    with the exit codes (`checker.commands.options.EXIT_CODES`)."""
    if isinstance(command, click.Group):
        for sub in command.commands.values():
            _shared(sub)
        return command
    if not any(p.name == "quiet" for p in command.params):
        command.params.extend(_VERBOSITY)
        command.epilog = EXIT_CODES
    return command


@click.group(cls=JobGroup, epilog=EXIT_CODES,
             context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="pathcheck")
def cli() -> None:
    """pathcheck: check a CNC tool path for gouges and interference, find the largest safe
    cutter and the best table angle B, and post corrected 4-axis G-code.

    \b
    pathcheck JOB.apt [--part PART] [--json FILE|-] [-o JOB.nc]   check a job
    pathcheck info FILE [--json FILE|-]                           what is in a CL or part file

    \b
    Shell completion (bash; zsh and fish alike):
    eval "$(_PATHCHECK_COMPLETE=bash_source pathcheck)"
    """


def _terminated(signum: int, frame: object) -> None:
    """SIGTERM ends the run like an interrupt: files being written are removed, not left
    half-written (`checker.atomic`); exit code 128 + the signal number."""
    raise SystemExit(128 + signum)


class Interrupted(BaseException):
    """Ctrl-C (SIGINT): raised where the program is, so that files being written are removed
    (`checker.atomic`); not a KeyboardInterrupt, which click turns into its "Aborted!"."""


def _interrupted(signum: int, frame: object) -> None:
    """The first SIGINT ends the run (exit EXIT_INTERRUPTED); further ones are ignored while it
    cleans up, so that the process never dies by the signal half-way."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    raise Interrupted


EXIT_OK, EXIT_FINDINGS, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3  # 1: the commands' own exit
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report an interrupted command


def _say(text: str) -> None:
    """One line on stderr, `pathcheck: ` first; control characters and line breaks (in a file
    name) escaped so that it stays one line."""
    click.echo(f"pathcheck: {printable(text)}", err=True)


def _os_error(err: OSError) -> str:
    """One line for a file the system refused (full disk, permission, missing folder)."""
    what = err.strerror or type(err).__name__
    return f"{err.filename}: {what}" if err.filename else f"{what} ({err})"


def _internal(err: Exception, argv: list[str]) -> None:
    """A bug: one line saying so and where the traceback was written; exit EXIT_INTERNAL."""
    from checker.crash_log import write_crash_log

    log = write_crash_log(err, argv)
    where = f"the traceback is in {log}" if log else "no log could be written"
    text = " ".join(f"{type(err).__name__}: {err}".split())[:300]
    _say(f"internal error (a bug in pathcheck, please report it with the log): {text}; {where}")
    sys.exit(EXIT_INTERNAL)


def main(argv: list[str] | None = None) -> None:
    """Console entry point: bad input is one line on stderr and exit code 2, never a traceback;
    a bug is one line and exit code 3 with its traceback in a log file (`checker.crash_log`)."""
    signal.signal(signal.SIGTERM, _terminated)
    before = signal.getsignal(signal.SIGINT)
    if before is signal.default_int_handler:  # not when ignored (nohup, a background job)
        signal.signal(signal.SIGINT, _interrupted)
    try:
        _run(list(sys.argv[1:] if argv is None else argv))
    finally:  # called in-process (tests) and not interrupted: Ctrl-C is the caller's again
        if signal.getsignal(signal.SIGINT) is _interrupted:
            signal.signal(signal.SIGINT, before)


def _run(args: list[str]) -> None:
    """`main` inside its signal handlers: every ending is one of the exit codes; the command's
    notes (`terminal.note`) are shown when it ends with exit 0 or 1."""
    show_notes(False)
    try:
        cli.main(args=args, prog_name="pathcheck", standalone_mode=False)
    except SystemExit as done:  # a command's own exit: 1 for findings
        show_notes(done.code in (None, EXIT_OK, EXIT_FINDINGS))
        raise
    except PathcheckError as err:
        _say(str(err))
        sys.exit(EXIT_INPUT)
    except MemoryError as err:
        _say(f"out of memory: {' '.join(str(err).split()) or 'no detail'}; expected input "
             "this machine can hold")
        sys.exit(EXIT_INPUT)
    except OSError as err:
        _say(_os_error(err))
        sys.exit(EXIT_INPUT)
    except click.exceptions.Exit as exc:
        show_notes(exc.exit_code in (EXIT_OK, EXIT_FINDINGS))
        sys.exit(exc.exit_code)
    except click.UsageError as exc:  # click's own three lines (usage, hint, error) as one
        where = f"; see '{exc.ctx.command_path} --help'" if exc.ctx is not None else ""
        _say(" ".join(exc.format_message().split()).rstrip(".") + where)
        sys.exit(EXIT_INPUT)
    except click.ClickException as exc:
        _say(" ".join(exc.format_message().split()))
        sys.exit(EXIT_INPUT)
    except (Interrupted, KeyboardInterrupt, click.exceptions.Abort):
        _say("interrupted")
        sys.exit(EXIT_INTERRUPTED)
    except Exception as err:
        _internal(err, args)
    show_notes(True)
    sys.exit(EXIT_OK)


if __name__ == "__main__":
    main()
