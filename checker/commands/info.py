"""`pathcheck info FILE [--json]`: what is in a CL file (dialect, units, operations, counts,
axis class, bounding box, unknown statements) or, for a part file, its surfaces."""

from __future__ import annotations

import json
from pathlib import Path

import click

PART_SUFFIXES = frozenset({".json", ".yaml", ".yml", ".step", ".stp", ".igs", ".iges", ".stl"})


@click.command()
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="print the JSON document instead of text")
def info(file: Path, as_json: bool) -> None:
    """What is in FILE: a CL file (APT-CL or NX CLSF) or a part (JSON/YAML/STEP/IGES/STL).

    \b
    pathcheck info job.apt
    pathcheck info job.apt --json
    """
    if file.suffix.lower() in PART_SUFFIXES:
        from checker.geometry.info import describe_part, format_part_info

        doc = describe_part(file)
        click.echo(json.dumps(doc, indent=2) if as_json else format_part_info(doc))
        return
    from checker.apt import read_cl
    from checker.apt.info import describe_toolpath, format_toolpath_info
    from checker.errors import PathcheckError

    toolpath = read_cl(file)
    if not len(toolpath.motions):
        raise PathcheckError("no motion: expected GOTO/, FROM/ or GODLTA/ records, found none",
                             path=file, code="parse")
    doc = describe_toolpath(toolpath)
    click.echo(json.dumps(doc, indent=2) if as_json else format_toolpath_info(doc))
