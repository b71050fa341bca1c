"""`pathcheck view RESULTS.json -o VIEW.html`: the interactive 3-D view of a checked job (one
offline HTML file: the part, the tool path coloured by verdict, the findings and the tool at
their pose); `--view FILE.html` on `check` and `check-gcode` writes it after the check, with the
stock after each operation (from --stock-out), the last coloured by its deviation to the design
(from --deviation-out as PLY), and the fixtures."""

from __future__ import annotations

from pathlib import Path

import click

from checker.commands import options as opt

view_option = click.option(
    "--view", "view_out", default=None, metavar="FILE.html",
    type=click.Path(dir_okay=False, path_type=Path),
    help="also write the interactive 3-D view of the check (one offline HTML file)")


def deviation_of(doc):
    """The part's measuring points and their deviation to the design from the PLY the check
    wrote (--deviation-out) and still there, or None."""
    from checker.view.scene import read_deviation

    machined = None if doc.stock is None else doc.stock.machined
    name = None if machined is None else machined.deviation_file
    if name is None or not name.endswith(".ply") or not Path(name).is_file():
        return None
    return read_deviation(name)


def stock_meshes(doc, beside: Path | None = None) -> list:
    """The stock after each operation as `(label, vertices, triangles)`, read from the STL files
    the check wrote (--stock-out) and still there; [] without them."""
    from checker.view.scene import stl_mesh

    if doc.stock is None:
        return []
    out = []
    for o in doc.stock.operations:
        if o.stl is not None and Path(o.stl).is_file():
            name = next((x.name for x in doc.operations if x.index == o.op), "")
            out.append(stl_mesh(f"op {o.op + 1} {name}".strip(), o.stl))
    return out


def write_after_check(view_out: Path | None, doc, *, toolpath=None, cutter=None, stock=None,
                      config=None) -> None:
    """`--view`: write the view of the check `doc` (the program `toolpath` checked, `cutter` the
    cutter given, `stock` its `StockRequest`); a view that cannot be made is one line on stderr,
    the check's own outputs are written all the same."""
    if view_out is None:
        return
    from checker.errors import PathcheckError, printable
    from checker.progress import step
    from checker.view.viewer_page import write_view

    try:
        with step("write the 3-D view"):
            fixtures = []
            if stock is not None and stock.fixtures:
                from checker.check.inputs import job_config
                from checker.stock.fixtures import load_fixture

                cfg = job_config(config)
                fixtures = [(f.name, f.vertices, f.triangles)
                            for f in (load_fixture(t, cfg) for t in stock.fixtures)]
            write_view(view_out, doc, toolpath=toolpath, cutter=cutter, config=config,
                       stock_meshes=stock_meshes(doc), fixtures=fixtures,
                       deviation=deviation_of(doc))
    except PathcheckError as err:
        click.echo(f"pathcheck: {printable(str(view_out))}: view not written: {err}", err=True)


@click.command()
@click.argument("results", type=click.Path(dir_okay=False, path_type=Path))
@opt.output_option("the HTML page [default: RESULTS with .html]", default=None)
@opt.machine_option(help="a G-code program's machine (name or TOML file), when its results "
                    "name none")
@opt.config_option()
def view(results: Path, output: Path | None, machine: str | None,
         config_path: Path | None) -> None:
    """Write the interactive 3-D view of the checked job RESULTS (a results JSON of `pathcheck
    JOB --json`): one HTML file that opens offline in a browser. The job's CL file and part
    are read again from the paths the document names (or beside it).

    \b
    pathcheck view out/mould.json -o out/mould.html
    pathcheck view out/prog.json --machine fanuc-hmc   # a check-gcode result
    """
    from pydantic import ValidationError

    from checker.commands.outputs import prepare_outputs
    from checker.errors import PathcheckError
    from checker.progress import step
    from checker.results import ResultsDocument
    from checker.view.viewer_page import write_view

    output = output if output is not None else results.with_suffix(".html")
    prepare_outputs([("-o", output, "3-D view")], [("RESULTS", results), ("--config", config_path)])
    try:
        text = results.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise PathcheckError(f"cannot read the results: {err}", path=results) from err
    try:
        doc = ResultsDocument.model_validate_json(text)
    except ValidationError as err:
        first = err.errors()[0]
        where = ".".join(str(x) for x in first["loc"]) or "the document"
        raise PathcheckError(f"not a pathcheck results document: {where}: {first['msg']}",
                             path=results, code="parse") from None
    with step("write the 3-D view"):
        path = write_view(output, doc, config=config_path, beside=results.parent,
                          stock_meshes=stock_meshes(doc, results.parent), machine=machine)
    click.echo(f"3-D view: {path} ({path.stat().st_size / 1e6:.1f} MB)")
