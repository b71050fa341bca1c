"""`pathcheck JOB.apt [--part PART] [--cutter "CUTTER/..."] [--json OUT] [-o JOB.nc]`: check a
job; exit 0 when clean, 1 with findings (gouge, interference, holder, crash) in the program
that is written, 2 on bad input."""

from __future__ import annotations

import sys
from pathlib import Path

import click


def _counts_line(c) -> str:
    return (f"ok {c.ok}  within tolerance {c.within_tolerance}  gouge {c.gouge}  interference "
            f"{c.interference}  holder {c.holder}  crash {c.crash}  inaccessible {c.inaccessible}")


def summary_view(doc):
    """Rich renderables of the results document: the job line, per operation what was done and
    its verdicts, the worst findings (line, depth, where, B) and the largest safe cutter (all
    of the program that is written)."""
    from rich.table import Table

    from checker.cutter import parse_cutter

    s, j = doc.summary, doc.job
    var = parse_cutter(j.cutter).size_symbol
    head = (f"{j.path}: {s.cl_points} poses, {s.move_points} moves ({s.poses_checked} poses "
            f"checked), {len(doc.operations)} operation(s), {j.axis_class}, tolerance up to "
            f"{s.tolerance:.4f} mm (part deviation {s.part_deviation:.4f}), {s.time_s:.2f} s\n"
            f"{'FINDINGS' if s.status == 'findings' else 'clean'}: {_counts_line(s.counts)}")
    if s.counts_cam is not None:
        head += f"\nat the CAM's own angles: {_counts_line(s.counts_cam)}"
    if doc.orientation is not None:
        o = doc.orientation
        head += (f"\nrotary motion: chosen {o.dp_total_rotation:.1f} deg (shortest path), "
                 f"greedy {o.greedy_total_rotation:.1f} deg, CAM {o.original_total_rotation:.1f}"
                 f" deg; {o.infeasible_points} points with no feasible B")
    if doc.gcode:
        head += f"\nG-code written: {doc.gcode}"
    out = [head]
    if len(doc.operations) > 1 or any(op.handling != "as-programmed" for op in doc.operations):
        t = Table(title="operations")
        for col in ("#", "cutter", "class", "written", "B (deg)", "tol (mm)", "findings"):
            t.add_column(col)
        for op in doc.operations:
            c = op.counts
            b = "-" if op.b_written is None else (
                f"{op.b_written[0]:.3f}" if op.b_written[0] == op.b_written[1]
                else f"{op.b_written[0]:.1f}..{op.b_written[1]:.1f}")
            t.add_row(str(op.index + 1), op.cutter.removeprefix("CUTTER/"), op.axis_class,
                      op.handling, b, f"{op.tolerance:.4f}",
                      str(c.gouge + c.interference + c.holder + c.crash))
        out.append(t)
    if s.worst:
        t = Table(title="worst findings")
        for col in ("line", "pose", "verdict", "depth (mm)", "B", "where (mm)"):
            t.add_column(col)
        for f in s.worst:
            where = f.point if f.point is not None else f.tip
            t.add_row(str(f.line), "CL" if f.kind == "cl" else f.kind, f.verdict,
                      f"{f.depth or 0:.4f}", "-" if f.b is None else f"{f.b:.3f}",
                      ", ".join(f"{x:.3f}" for x in where))
        out.append(t)
    out.append("largest safe cutter (advice): " + (
        "unbounded" if s.largest_safe_cutter is None
        else f"{var} = {s.largest_safe_cutter:.4f} mm")
        + f"; largest safe standard cutter: {s.largest_safe_standard_cutter or 'none'}")
    return out


def parse_b_range(text: str | None) -> tuple[float, float] | None:
    """"LO:HI" in degrees -> (lo, hi); None stays None."""
    from checker.errors import PathcheckError

    if text is None:
        return None
    parts = text.split(":")
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise PathcheckError(f"--b-range '{text}': expected LO:HI in degrees, e.g. -30:60",
                             code="usage") from None
    return lo, hi


def record(doc) -> None:
    """Record the check in the results store; a store problem (locked, a full disk) is a
    one-line note on stderr, not a failure."""
    from checker.errors import PathcheckError
    from checker.store import ResultsStore

    try:
        with ResultsStore() as store:
            store.record_job(doc, elapsed_s=doc.summary.time_s, source="cli")
    except PathcheckError as err:
        click.echo(f"pathcheck: note: not recorded in the results store: {err}", err=True)


@click.command()
@click.argument("job", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--part", "part_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="part file (default: the file beside JOB with the same stem)")
@click.option("--cutter", "cutter_text", default=None, help='override the cutter, "CUTTER/..."')
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="configuration TOML overriding the shipped defaults")
@click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="write the results document (JSON) here; - for stdout")
@click.option("-o", "gcode_out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="write the corrected 4-axis G-code here (atomically)")
@click.option("--machine", default=None,
              help="a shipped machine's name or a machine TOML file (default: the CL file's "
                   "PPRINT/MACHINE, else fanuc-hmc)")
@click.option("--b-range", "b_range", default=None, metavar="LO:HI",
              help="B range searched for the best table angle, degrees (default from config)")
@click.option("--reorient", is_flag=True,
              help="plan the table angle B for a 3-axis path (run it on the 4-axis machine)")
@click.option("--tool", "tool_name", default=None,
              help="the real cutter from the tool library, with its shank "
                   "and holder, e.g. BALL-D6")
@click.option("--part-transform", default=None, metavar="RX,RY,RZ,DX,DY,DZ|3x4",
              help="place a part exported in another frame: rotations about X, Y, Z (degrees) "
                   "then an offset (mm), or a 3x4 matrix row by row")
@click.option("--no-store", is_flag=True, help="do not record this check in the results store")
def check(job, part_path, cutter_text, config_path, json_out, gcode_out, machine, b_range,
          reorient, tool_name, part_transform, no_store) -> None:
    """Check JOB (APT-CL or NX CLSF) against its part: allowable cutter, verdict and margin at
    every CC point.

    \b
    pathcheck samples/mould/mould.apt
    pathcheck samples/mould/mould.apt --json out/mould.json
    """
    from checker.atomic import check_writable, make_parent
    from checker.errors import PathcheckError
    from checker.job import check_job

    if not job.is_file():
        raise PathcheckError("job file not found: expected an existing CL file", path=job)
    for target, what in ((gcode_out, "G-code"), (json_out, "results JSON")):
        if target is not None and str(target) != "-":
            check_writable(target, what)
            make_parent(target, what)
    cutter = cutter_text
    if tool_name is not None:
        if cutter_text is not None:
            raise PathcheckError("give --cutter or --tool, not both", code="usage")
        from checker.tool_library import load_tool_library

        cutter = load_tool_library()[tool_name]
    try:
        doc = check_job(job, part_path=part_path, cutter=cutter, config=config_path,
                        output=gcode_out, machine=machine, b_range=parse_b_range(b_range),
                        reorient=reorient, part_transform=part_transform)
    except PathcheckError as err:
        checked = getattr(err, "document", None)  # the check ran, its program was not written
        if checked is not None and not no_store:
            record(checked)
        raise
    finish(doc, json_out, store=not no_store)


def finish(doc, json_out: Path | None, *, store: bool) -> None:
    """Print the summary, record the check, write the JSON (a file that cannot be written is
    exit 2, the check recorded all the same); exit 1 when there are findings. `json_out` "-":
    the JSON alone on stdout, the summary on stderr (docs/cam-command.md)."""
    from rich.console import Console

    from checker.atomic import make_parent, write_file

    to_stdout = json_out is not None and str(json_out) == "-"
    console = Console(stderr=to_stdout)
    for item in summary_view(doc):
        console.print(item)
    if store:
        record(doc)
    if to_stdout:
        click.echo(doc.model_dump_json(indent=1))
    elif json_out is not None:
        make_parent(json_out, "results JSON")
        write_file(json_out, doc.model_dump_json(indent=1), what="results JSON")
    if doc.summary.status == "findings":
        sys.exit(1)
