"""`pathcheck map --part PART --cutter ... [--grid 21x21] [--tool-library TOOLS.toml] [-o DIR]`:
allowable-cutter and standard-cutter maps of every surface (PNG + JSON)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import click

from checker.atomic import write_file
from checker.commands import options as opt
from checker.errors import PathcheckError
from checker.progress import step


def parse_grid(text: str) -> tuple[int, int]:
    """`21x21` -> (21, 21); each at least 2."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or min(int(m.group(1)), int(m.group(2))) < 2:
        raise PathcheckError(f"--grid: expected NUxNV with both >= 2 (e.g. 21x21), found {text!r}")
    return int(m.group(1)), int(m.group(2))


@click.command("map")
@opt.part_option(required=True, help="part file (geomdl JSON/YAML, STEP, IGES, STL)")
@opt.cutter_option(help='cutter family, e.g. "CUTTER/10,5", in mm unless --units')
@opt.units_option(default_text="mm")
@opt.tool_option()
@opt.tool_library_option(hidden_names=("--tools",))
@click.option("--grid", "grid_text", default="21x21", show_default=True,
              help="iso-parametric CC points per surface")
@opt.output_option("folder for the PNG and JSON", hidden_names=("--out",), folder=True,
                   default=Path("out/map"))
def map_command(part_path, cutter_text, units, tool_name, tool_library, grid_text,
                output) -> None:
    """Allowable-cutter map and standard-cutter map of the part (thesis figs 3-2, 4-2, 4-3)
    for the family of --cutter (or --tool), with the standard cutters of the tool library.

    \b
    pathcheck map --part samples/mould/mould.json --cutter "CUTTER/10,5" -o out/map
    """
    import numpy as np

    from checker.engine.maps import allowable_maps, maps_document
    from checker.geometry import load_part
    from checker.geometry.sampling import sample_part
    from checker.report.pictures import draw_maps
    from checker.tool_library import load_tool_library

    cutter = opt.cutter_family(cutter_text, tool_name, tool_library, units)
    grid = parse_grid(grid_text)
    lib = load_tool_library(tool_library)
    r = cutter.family_corner
    tools = lib.family(cutter.kind, r, theta=cutter.theta)
    with step("load the part"):
        part = load_part(part_path)
    if not part.surfaces:
        raise PathcheckError("a map needs a part with surfaces (u, v); this one is a mesh",
                             path=part_path, code="part")
    with step("sample the part"):
        samples = sample_part(part)
    with step("allowable cutter over the grid"):
        maps = allowable_maps(part, samples, cutter, grid, tools)
    with step("draw the maps"):
        files = draw_maps(maps, cutter, tools, output, part_path.name)
    doc = maps_document(maps, cutter, tools)
    write_file(output / "map.json", json.dumps(doc, indent=1), what="map JSON")
    sizes = np.concatenate([m.size[m.kept] for m in maps])
    fin = sizes[np.isfinite(sizes)]
    name = cutter.size_symbol
    if not sizes.size:
        smallest = "none: no grid point lies inside the trimmed faces (try a finer --grid)"
    elif fin.size:
        smallest = f"{name} min {fin.min():.4f} mm"
    else:
        smallest = f"{name} unbounded everywhere (no point limits the cutter)"
    click.echo(f"{len(sizes)} CC points on {len(maps)} surfaces; allowable {smallest}; "
               f"{len(tools)} standard {cutter.kind} cutters")
    for f in [*files, output / "map.json"]:
        click.echo(f"wrote {f}")
