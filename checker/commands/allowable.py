"""`pathcheck allowable --part PART --cc CC.csv --cutter "CUTTER/..." [--axis i,j,k]
[--method pso] [--json FILE|-]`: the allowable cutter size at given CC points."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import click
import numpy as np

from checker.commands import options as opt
from checker.errors import PathcheckError

CC_COLUMNS = ("x", "y", "z", "nx", "ny", "nz")
# a decimal number as a CSV writes it (Python's float() also takes 1_0, nan, infinity: not these)
_NUMBER = re.compile(r"\s*[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\s*")


def read_cc_csv(path: Path, *, lines_out: list[int] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """CC points (N, 3) and unit normals (N, 3) from a CSV with the header x,y,z,nx,ny,nz;
    `lines_out` receives each row's 1-based file line."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise PathcheckError(f"cannot read CC file: {err}", path=path, code="input") from err
    if not lines:
        raise PathcheckError("empty CC file, expected a header x,y,z,nx,ny,nz", path=path, line=1)
    head = [h.strip().lower() for h in lines[0].split(",")]
    if head != list(CC_COLUMNS):
        raise PathcheckError(f"expected the header x,y,z,nx,ny,nz, found {lines[0][:60]!r}",
                             path=path, line=1)
    rows = []
    for no, text in enumerate(lines[1:], 2):
        if not text.strip():
            continue
        cells = text.split(",")
        if len(cells) != 6:
            raise PathcheckError(f"expected 6 values, found {len(cells)}", path=path, line=no)
        bad = [c.strip() for c in cells if not _NUMBER.fullmatch(c)]
        if bad:
            raise PathcheckError(f"expected 6 decimal numbers, found {bad[0][:30]!r} in "
                                 f"{text.strip()[:60]!r}", path=path, line=no)
        vals = [float(c) for c in cells]
        if not np.isfinite(vals).all():
            raise PathcheckError(f"expected finite numbers, found {text.strip()[:60]!r}",
                                 path=path, line=no)
        if np.linalg.norm(vals[3:]) < 1e-9:
            raise PathcheckError("expected a non-zero normal (nx, ny, nz), found 0,0,0",
                                 path=path, line=no)
        rows.append(vals)
        if lines_out is not None:
            lines_out.append(no)
    if not rows:
        raise PathcheckError("expected at least one CC point after the header", path=path, line=2)
    a = np.array(rows)
    return a[:, :3], a[:, 3:] / np.linalg.norm(a[:, 3:], axis=1)[:, None]


def check_reach(cc: np.ndarray, lines: list[int], bbox: np.ndarray, path: Path) -> None:
    """CC points lie on the part: one farther from the part's box than the box's diagonal is
    an error naming its line (the search near it would mean nothing)."""
    lo, hi = np.asarray(bbox[0], float), np.asarray(bbox[1], float)
    reach = max(float(np.linalg.norm(hi - lo)), 1.0)
    outside = (np.maximum(lo - cc, 0.0) + np.maximum(cc - hi, 0.0)).max(axis=1)
    far = np.flatnonzero(~(outside <= reach))
    if len(far):
        k = far[0]
        raise PathcheckError(
            f"CC point ({', '.join(f'{v:.6g}' for v in cc[k])}) lies {outside[k]:.6g} mm "
            f"outside the part's box: expected points on the part (within {reach:.6g} mm)",
            path=path, line=lines[k], code="input")


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
    from checker.commands.terminal import text_console
    from checker.config import load_config
    from checker.engine import allowable as run
    from checker.engine.document import allowable_document, allowable_table
    from checker.geometry import load_part
    from checker.geometry.sampling import sample_part
    from checker.progress import step

    cutter = opt.cutter_family(cutter_text, tool_name, tool_library, units)
    config = load_config(config_path)
    axis = parse_axis(axis_text)
    lines: list[int] = []
    cc, normals = read_cc_csv(cc_path, lines_out=lines)
    t0 = time.perf_counter()
    with step("load the part"):
        part = load_part(part_path)
    check_reach(cc, lines, part.bbox, cc_path)
    t1 = time.perf_counter()
    with step("sample the part"):
        tp = sample_part(part)
    t2 = time.perf_counter()
    with step("allowable cutter search"):
        res = run(tp, part, cutter, cc, normals, axis, method=method, seed=seed, config=config)
    t3 = time.perf_counter()
    doc = allowable_document(res, cc, normals, cutter, method,
                             {"load_s": t1 - t0, "sample_s": t2 - t1, "search_s": t3 - t2})
    if b_range is not None:
        from checker.commands.check import parse_b_range
        from checker.four_axis.job import best_b_points

        lo, hi = parse_b_range(b_range)
        t4 = time.perf_counter()
        best_b_points(doc, tp, part, cutter, cc, normals, (lo, hi), config)
        doc["timing"]["b_search_s"] = round(time.perf_counter() - t4, 6)
    to_stderr = opt.json_to_stdout(json_out)
    text_console(stderr=to_stderr).print(allowable_table(doc))
    opt.say(f"{len(cc)} CC points; load {t1 - t0:.3f} s, sample {t2 - t1:.3f} s, "
            f"search {t3 - t2:.3f} s", json_out=json_out)
    if json_out is not None:
        opt.write_json(json_out, json.dumps(doc, indent=2), what="results JSON")
