"""`pathcheck info FILE [--json FILE|-]`: what is in a CL file (dialect, units, operations, counts,
axis class, bounding box, unknown statements) or, for a part file, its surfaces."""

from __future__ import annotations

import json
from pathlib import Path

import click

from checker.commands import options as opt

PART_SUFFIXES = frozenset({".json", ".yaml", ".yml", ".step", ".stp", ".igs", ".iges", ".stl"})


@click.command()
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@opt.json_option("the description")
def info(file: Path, json_out: Path | None) -> None:
    """What is in FILE: a CL file (APT-CL or NX CLSF) or a part (JSON/YAML/STEP/IGES/STL).

    \b
    pathcheck info job.apt
    pathcheck info job.apt --json -          # the JSON document alone on stdout
    pathcheck info job.apt --json job.json   # the text, and the document in job.json
    """
    from checker.commands.outputs import prepare_outputs

    prepare_outputs([("--json", json_out, "info JSON")], [("the file", file)])
    if file.suffix.lower() in PART_SUFFIXES:
        from checker.geometry.part_info import describe_part, format_part_info
        from checker.progress import step

        with step("read the part"):  # a STEP or IGES file: seconds in OpenCASCADE
            doc = describe_part(file)
        _show(doc, format_part_info(doc), json_out)
        return
    from checker.apt import read_cl
    from checker.apt.toolpath_info import describe_toolpath, format_toolpath_info
    from checker.errors import PathcheckError
    from checker.progress import step

    with step("read the CL file"):
        toolpath = read_cl(file)
    if not len(toolpath.motions):
        raise PathcheckError("no motion: expected GOTO/, FROM/ or GODLTA/ records, found none",
                             path=file, code="parse")
    doc = describe_toolpath(toolpath)
    _show(doc, format_toolpath_info(doc), json_out)


def _show(doc: dict, text: str, json_out: Path | None) -> None:
    """The text on stdout unless `--json -` puts the document there; the document to FILE."""
    if not opt.json_to_stdout(json_out):
        click.echo(text)
    if json_out is not None:
        opt.write_json(json_out, json.dumps(doc, indent=2), what="info JSON")
