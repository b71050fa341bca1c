"""`pathcheck allowable --part PART --cc CC.csv --cutter "CUTTER/..." [--axis i,j,k]
[--method pso] [--json FILE|-]`: the allowable cutter size at given CC points."""

from __future__ import annotations

import json
from pathlib import Path

import click
import numpy as np

from checker.commands import options as opt
from checker.errors import PathcheckError


def parse_axis(text: str) -> np.ndarray:
    """`i,j,k` -> unit (3,) axis."""
    try:
        v = np.array([float(t) for t in text.split(",")])
    except ValueError:
        v = np.zeros(0)
    if v.shape != (3,) or not np.isfinite(v).all() or np.linalg.norm(v) < 1e-12:
        raise PathcheckError(f"--axis: expected three numbers i,j,k not all 0, found {text!r}")
    return v / np.linalg.norm(v)


@click.command()
@opt.part_option(required=True, help="part file (geomdl JSON/YAML, STEP, IGES, STL), in the "
                 "frame of the CC points")
@click.option("--cc", "cc_path", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="CSV with header x,y,z,nx,ny,nz (part frame, mm)")
@opt.cutter_option(help='cutter family, e.g. "CUTTER/10,2", in mm unless --units')
@opt.units_option(default_text="mm, as the CC points")
@opt.tool_option()
@opt.tool_library_option()
@click.option("--axis", "axis_text", default="0,0,1", show_default=True,
              help="tool axis i,j,k (tip -> spindle)")
@click.option("--method", type=click.Choice(["exact", "pso"]), default="exact", show_default=True,
              help="exact: this engine; pso: the thesis's PSO baseline")
@click.option("--seed", type=int, default=None, help="random seed of the PSO baseline")
@opt.config_option()
@opt.json_option("the result document (its main output; the table goes to stderr with '-')")
@click.option("--b-range", "b_range", default=None, metavar="LO:HI",
              help="also find the best table angle B in LO:HI degrees (4-axis, rotary about Y): "
                   "adds b_best, allowable_at_best and b_feasible for --cutter")
def allowable(part_path, cc_path, cutter_text, units, tool_name, tool_library, axis_text,
              method, seed, config_path, json_out, b_range) -> None:
    """The largest gouge- and interference-free cutter of the family of --cutter (or --tool)
    at each CC point (R for flat, bull-nose and APT cutters; r for ball and tapered ball).

    \b
    pathcheck allowable --part mould.json --cc cc.csv --cutter "CUTTER/10,5"
    pathcheck allowable --part mould.json --cc cc.csv --cutter "CUTTER/10,2" --json out.json
    """
    from checker.cc_csv import read_cc_csv
    from checker.cc_points import Rows, check_reach
    from checker.commands.check import parse_b_range
    from checker.commands.outputs import prepare_outputs
    from checker.commands.terminal import text_console
    from checker.config import load_config
    from checker.engine.allowable_output import allowable_table
    from checker.geometry import load_part
    from checker.operations.allowable import allowable_at_points, check_b_request, sampled_part

    prepare_outputs([("--json", json_out, "results JSON")],
                    [("--part", part_path), ("--cc", cc_path), ("--config", config_path),
                     ("--tool-library", tool_library)])
    cutter = opt.cutter_family(cutter_text, tool_name, tool_library, units)
    config = load_config(config_path)
    axis = parse_axis(axis_text)
    b = parse_b_range(b_range)
    check_b_request(b, config)
    lines: list[int] = []
    cc, normals = read_cc_csv(cc_path, lines_out=lines)

    def load():  # the CC points must lie on the part: say so before sampling it
        part = load_part(part_path, geometry=config.geometry)
        check_reach(cc, part.bbox, Rows(cc_path, lines))
        return part

    part = sampled_part(load, config)
    doc = allowable_at_points(part, cutter, cc, normals, axis, config, method=method, seed=seed,
                              b_range=b)
    t = doc["timing"]
    to_stderr = opt.json_to_stdout(json_out)
    text_console(stderr=to_stderr).print(allowable_table(doc))
    opt.say(f"{len(cc)} CC points; load {t['load_s']:.3f} s, sample {t['sample_s']:.3f} s, "
            f"search {t['search_s']:.3f} s", json_out=json_out)
    if json_out is not None:
        opt.write_json(json_out, json.dumps(doc, indent=2), what="results JSON")
