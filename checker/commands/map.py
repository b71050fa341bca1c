"""`pathcheck map PART --cutter ... [--grid 21x21] [--tools TOOLS.toml] [--out DIR]`:
allowable-cutter and standard-cutter maps of every surface (PNG + JSON)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import click

from checker.atomic import write_file
from checker.errors import PathcheckError


def parse_grid(text: str) -> tuple[int, int]:
    """`21x21` -> (21, 21); each at least 2."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or min(int(m.group(1)), int(m.group(2))) < 2:
        raise PathcheckError(f"--grid: expected NUxNV with both >= 2 (e.g. 21x21), found {text!r}")
    return int(m.group(1)), int(m.group(2))


@click.command("map")
@click.argument("part_path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--cutter", "cutter_text", required=True, help='cutter family, e.g. "CUTTER/10,5"')
@click.option("--grid", "grid_text", default="21x21", show_default=True,
              help="iso-parametric CC points per surface")
@click.option("--tools", "tools_path", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="tool library (default: the shipped one)")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("out/map"), show_default=True, help="folder for the PNG and JSON")
def map_command(part_path, cutter_text, grid_text, tools_path, out_dir) -> None:
    """Allowable-cutter map and standard-cutter map of PART (thesis figs 3-2, 4-2, 4-3).

    \b
    pathcheck map samples/mould/mould.json --cutter "CUTTER/10,5" --out out/map
    """
    import numpy as np

    from checker.cutter import parse_cutter
    from checker.engine.maps import allowable_maps, draw_maps, maps_document
    from checker.geometry import load_part
    from checker.geometry.sampling import sample_part
    from checker.tool_library import load_tool_library

    cutter = parse_cutter(cutter_text)
    grid = parse_grid(grid_text)
    lib = load_tool_library(tools_path)
    r = cutter.family_corner
    tools = lib.family(cutter.kind, r, theta=cutter.theta)
    part = load_part(part_path)
    if not part.surfaces:
        raise PathcheckError("a map needs a part with surfaces (u, v); this one is a mesh",
                             path=part_path, code="part")
    maps = allowable_maps(part, sample_part(part), cutter, grid, tools)
    files = draw_maps(maps, cutter, tools, out_dir, part_path.name)
    doc = maps_document(maps, cutter, tools)
    write_file(out_dir / "map.json", json.dumps(doc, indent=1), what="map JSON")
    sizes = np.concatenate([m.size[m.kept] for m in maps])
    fin = sizes[np.isfinite(sizes)]
    name = "r" if r is None else "R"
    if not sizes.size:
        smallest = "none: no grid point lies inside the trimmed faces (try a finer --grid)"
    elif fin.size:
        smallest = f"{name} min {fin.min():.4f} mm"
    else:
        smallest = f"{name} unbounded everywhere (no point limits the cutter)"
    click.echo(f"{len(sizes)} CC points on {len(maps)} surfaces; allowable {smallest}; "
               f"{len(tools)} standard {cutter.kind} cutters")
    for f in [*files, out_dir / "map.json"]:
        click.echo(f"wrote {f}")
