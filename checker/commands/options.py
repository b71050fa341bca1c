"""The options every command spells the same way (`--part`, `--cutter`, `--tool`,
`--tool-library`, `--machine`, `--config`, `--store`, `-o/--output`, `--json FILE|-`,
`--units`, the stock and fixture options) and the exit-code text of every command's help. An
old spelling kept for scripts is a hidden alias of its option (`AliasOption`), not a second
option."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click

EXIT_CODES = (
    "\b\nExit codes: 0 clean, 1 findings, 2 bad input, usage, a file that cannot be read or\n"
    "written, or out of memory (one line naming the file), 3 internal error (a bug: one line,\n"
    "the traceback in a log file, $PATHCHECK_LOG_DIR or ~/.local/state/pathcheck/log),\n"
    "130 interrupted, 128 + N ended by signal N."
)

_FILE = click.Path(dir_okay=False, path_type=Path)


class AliasOption(click.Option):
    """An option whose `hidden` names (old spellings) still parse but are not in the help."""

    def __init__(self, *args, hidden_names: tuple[str, ...] = (), **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.hidden_names = frozenset(hidden_names)

    def get_help_record(self, ctx: click.Context):
        shown = self.opts
        self.opts = [o for o in shown if o not in self.hidden_names]
        try:
            return super().get_help_record(ctx)
        finally:
            self.opts = shown


def part_option(*, required: bool = False, help: str = "part file (geomdl JSON/YAML, STEP, "
                "IGES, STL), in the frame of the CL file") -> Callable:
    """`--part FILE` -> `part_path`."""
    return click.option("--part", "part_path", type=_FILE, required=required, default=None,
                        help=help)


def cutter_option(*, required: bool = False, help: str = 'cutter, e.g. "CUTTER/10,2"; '
                  "dimensions in the job's units unless --units") -> Callable:
    """`--cutter "CUTTER/..."` -> `cutter_text`."""
    return click.option("--cutter", "cutter_text", required=required, default=None, help=help)


def tool_option() -> Callable:
    """`--tool NAME` -> `tool_name`: a cutter of the tool library, with its shank and holder."""
    return click.option("--tool", "tool_name", default=None, metavar="NAME",
                        help="the real cutter from the tool library (--tool-library), with its "
                             "shank and holder, e.g. BALL-D6")


def tool_library_option(*, hidden_names: tuple[str, ...] = ()) -> Callable:
    """`--tool-library FILE` -> `tool_library`."""
    return click.option("--tool-library", *hidden_names, "tool_library", cls=AliasOption,
                        hidden_names=hidden_names, type=_FILE, default=None,
                        help="tool library TOML [default: the shipped one]")


def units_option(*, default_text: str = "the job's units") -> Callable:
    """`--units mm|inch` -> `units`: the unit of --cutter's dimensions."""
    return click.option("--units", "units", type=click.Choice(["mm", "inch"]), default=None,
                        help=f"unit of --cutter's dimensions [default: {default_text}]")


def machine_option(*, help: str = "a shipped machine's name or a machine TOML file "
                   "[default: the CL file's PPRINT/MACHINE, else fanuc-hmc]") -> Callable:
    """`--machine NAME|FILE` -> `machine`."""
    return click.option("--machine", "machine", default=None, metavar="NAME|FILE", help=help)


def config_option(*, help: str = "configuration TOML overriding the shipped defaults"
                  ) -> Callable:
    """`--config FILE` -> `config_path`."""
    return click.option("--config", "config_path", type=_FILE, default=None, help=help)


def store_option(*, help: str = "results store [default: PATHCHECK_STORE or config "
                 "store.path]") -> Callable:
    """`--store FILE` -> `store_path`."""
    return click.option("--store", "store_path", type=_FILE, default=None, metavar="FILE",
                        help=help)


def output_option(help: str, *, hidden_names: tuple[str, ...] = (), folder: bool = False,
                  default: Path | None = None) -> Callable:
    """`-o/--output FILE` (a folder with `folder`) -> `output`: the command's main output."""
    kind = click.Path(file_okay=False, path_type=Path) if folder else _FILE
    return click.option("-o", "--output", *hidden_names, "output", cls=AliasOption,
                        hidden_names=hidden_names, type=kind, default=default,
                        show_default=default is not None, help=help)


def json_option(what: str = "the results document") -> Callable:
    """`--json FILE|-` -> `json_out`: write the JSON document to FILE, or to stdout with `-`
    (then the human text goes to stderr)."""
    return click.option("--json", "json_out", type=click.Path(dir_okay=False, allow_dash=True,
                                                              path_type=Path),
                        default=None, metavar="FILE|-",
                        help=f"write {what} as JSON to FILE, or to stdout with '-' (the text "
                             "then goes to stderr)")


def stock_options(command: Callable) -> Callable:
    """`--stock`, `--fixture` (repeatable), `--stock-resolution`, `--stock-out`,
    `--deviation-out`, `--leave` -> `stock_text, fixtures, stock_resolution, stock_out,
    deviation_out, leave` (`stock_request` makes the request)."""
    for option in reversed((
            click.option("--stock", "stock_text", default=None, metavar="SPEC",
                         help="check against the stock, part frame, mm: box:+M (a margin "
                              "around the part; +MX,+MY,+MZ per axis; six per side), "
                              "box:X0,Y0,Z0,X1,Y1,Z1, cylinder:AXIS:+M or "
                              "cylinder:AXIS[@C1,C2]:D,START,END (bar stock), a solid (STL, "
                              "STEP, IGES), or cl (the stock the CL file states)"),
            click.option("--fixture", "fixtures", multiple=True, metavar="FILE[@RX,..,DZ]",
                         help="a fixture (vise, clamp, table: STL, STEP, IGES), placed by "
                              "rotations about X, Y, Z (degrees) then an offset (mm); "
                              "repeatable"),
            click.option("--stock-resolution", "stock_resolution", type=float, default=None,
                         metavar="MM", help="ray spacing of the stock model, mm [default: from "
                                            "the stock's size]"),
            click.option("--stock-out", "stock_out",
                         type=click.Path(file_okay=False, path_type=Path), default=None,
                         metavar="DIR", help="write the stock after each operation and at the "
                                             "end here (STL)"),
            click.option("--deviation-out", "deviation_out",
                         type=click.Path(dir_okay=False, path_type=Path), default=None,
                         metavar="FILE", help="write the part with the machined part's "
                         "deviation per vertex (.ply or .vtk; a .png map beside it)"),
            click.option("--leave", "leave", type=float, default=0.0, metavar="MM",
                         help="stock left on the part on purpose, mm (with THICK in the CL "
                              "file, the larger per operation) [default: 0]"))):
        command = option(command)
    return command


def machine_check_options(command: Callable) -> Callable:
    """`--machine-check`, `--machine-clearance MM` -> `machine_check, machine_clearance`
    (`machine_clearance_of` checks them)."""
    command = click.option(
        "--machine-clearance", "machine_clearance", type=float, default=None, metavar="MM",
        help="closer than this between the machine's solids, the tool and the work is a "
             "finding, mm [default: 1]; implies --machine-check")(command)
    return click.option(
        "--machine-check", "machine_check", is_flag=True,
        help="check the machine's own solids (its [[components]]) against each other, the tool, "
             "the part, the stock and the fixtures along the motion")(command)


def machine_clearance_of(machine_check: bool, clearance: float | None, machine) -> float | None:
    """The clearance of the machine check (mm), None when it is not asked; a machine without
    components or a clearance that is not a distance >= 0 is a usage error, before any work
    (`checker.collide.section.asked_clearance`)."""
    if not machine_check and clearance is None:
        return None
    from checker.collide.section import asked_clearance

    return asked_clearance(machine, clearance)


def stock_request(stock_text: str | None, fixtures: tuple[str, ...],
                  stock_resolution: float | None, stock_out: Path | None,
                  deviation_out: Path | None = None, leave: float = 0.0):
    """The `checker.stock.request.StockRequest` of the stock options, checked before the run:
    the stock's text (`checker.stock.spec.parse_stock`), the fixtures' files and placements, a
    resolution that is a positive number of mm, a `--stock-out` folder that can be made, a
    `--deviation-out` file (.ply, .vtk) that can be written and a `--leave` of 0 to 100 mm."""
    from checker.errors import PathcheckError
    from checker.stock.fixtures import fixture_placement
    from checker.stock.request import StockRequest
    from checker.stock.spec import parse_stock

    if stock_text is not None:
        parse_stock(stock_text)
    for text in fixtures:
        fixture_placement(text)

    if stock_resolution is not None and not (0.001 <= stock_resolution <= 100.0):
        raise PathcheckError(f"--stock-resolution {stock_resolution:g}: expected a ray spacing "
                             "between 0.001 and 100 mm", code="usage")
    if stock_out is not None:
        from checker.atomic import check_writable

        if stock_text is None:
            raise PathcheckError("--stock-out writes the stock: expected --stock too",
                                 code="usage")
        if stock_out.exists() and not stock_out.is_dir():
            raise PathcheckError("--stock-out: expected a folder, found a file", path=stock_out,
                                 code="usage")
        check_writable(stock_out / "stock_final.stl", "stock STL")  # created when written
    if not (0.0 <= leave <= 100.0):
        raise PathcheckError(f"--leave {leave:g}: expected a thickness between 0 and 100 mm",
                             code="usage")
    if deviation_out is not None:
        from checker.atomic import check_writable

        if stock_text is None:
            raise PathcheckError("--deviation-out compares the machined part: expected --stock "
                                 "too", code="usage")
        if deviation_out.suffix.lower() not in (".ply", ".vtk"):
            raise PathcheckError("--deviation-out: expected a .ply or .vtk file",
                                 path=deviation_out, code="usage")
        check_writable(deviation_out, "deviation file")
        check_writable(deviation_out.with_suffix(".png"), "deviation map")
    return StockRequest(stock_text, tuple(fixtures), stock_resolution, stock_out,
                        deviation_out, leave)


def json_to_stdout(json_out: Path | None) -> bool:
    """True when `--json -` asks for the JSON document on stdout."""
    return json_out is not None and str(json_out) == "-"


def write_json(json_out: Path, text: str, *, what: str) -> None:
    """The JSON document to `json_out` (atomically) or to stdout for `-`."""
    if json_to_stdout(json_out):
        click.echo(text)
        return
    from checker.atomic import make_parent, write_file

    make_parent(json_out, what)
    write_file(json_out, text if text.endswith("\n") else text + "\n", what=what)


def say(text: str, *, json_out: Path | None = None) -> None:
    """A line of human text: stdout, or stderr when `--json -` owns stdout."""
    click.echo(text, err=json_to_stdout(json_out))


def cutter_choice(cutter_text: str | None, tool_name: str | None, tool_library: Path | None):
    """The cutter asked for: `--cutter` text, or the `--tool` of the tool library (a `Cutter`
    with its shank and holder), or None; both is a usage error."""
    if tool_name is None:
        return cutter_text
    from checker.errors import PathcheckError
    from checker.tool_library import load_tool_library

    if cutter_text is not None:
        raise PathcheckError("give --cutter or --tool, not both", code="usage")
    return load_tool_library(tool_library)[tool_name]


def cutter_family(cutter_text: str | None, tool_name: str | None, tool_library: Path | None,
                  units: str | None):
    """The `Cutter` whose family `allowable` and `map` search: `--cutter` (read in `units`,
    default mm) or `--tool`; neither is a usage error."""
    from checker.cutter import Cutter, parse_cutter_in
    from checker.errors import PathcheckError

    cutter = cutter_choice(cutter_text, tool_name, tool_library)
    if cutter is None:
        raise PathcheckError("give --cutter or --tool: the cutter family", code="usage")
    return cutter if isinstance(cutter, Cutter) else parse_cutter_in(cutter, units or "mm")


def store_of(store_path: Path | None, config_path: Path | None) -> Path | None:
    """The store to record in: --store, else --config's store.path, else the default (None)."""
    if store_path is not None or config_path is None:
        return store_path
    from checker.config import load_config

    return load_config(config_path).store.resolved_path()


def open_store(store_path: Path | None) -> None:
    """Fail before the run when the results store cannot take records: a folder, a file that
    is corrupt, from a newer pathcheck or another program's SQLite file, or locked past the
    timeout (PathcheckError naming it, exit 2; the file is left untouched). A store that
    fails later, while recording (a full disk), is a note (`checker.commands.check.record`)."""
    from checker.store import ResultsStore

    ResultsStore(store_path).close()
