"""`pathcheck JOB.apt [--part PART] [--cutter "CUTTER/..."] [--json FILE|-] [-o JOB.nc]`: check a
job; exit 0 when clean, 1 with findings (gouge, interference, holder, crash; with
--machine-check, machine collisions) in the program that is written, 2 on bad input."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from checker.commands import options as opt
from checker.commands.view import view_option, write_after_check


def _counts_line(c) -> str:
    return (f"ok {c.ok}  within tolerance {c.within_tolerance}  gouge {c.gouge}  interference "
            f"{c.interference}  holder {c.holder}  crash {c.crash}  inaccessible {c.inaccessible}"
            + (f"  machine {c.machine}" if c.machine else ""))


def short_cutter(apt: str) -> str:
    """`CUTTER/12.0,6.0,0.0,0.0,0.0,0.0,0.0` -> `CUTTER/12,6` (trailing zeros dropped)."""
    word, _, rest = apt.partition("/")
    values = [float(v) for v in rest.split(",")] if rest else []
    while len(values) > 1 and values[-1] == 0.0:
        values.pop()
    return f"{word}/" + ",".join(f"{v:g}" for v in values)


def summary_view(doc):
    """Rich renderables of the results document: the job line, per operation what was done and
    its verdicts, the worst findings (line, depth, where, B) and the largest safe cutter (all
    of the program that is written)."""
    from rich.table import Table

    from checker.commands.terminal import fixed
    from checker.cutter import parse_cutter
    from checker.results import findings_in, machine_line, stock_line

    s, j = doc.summary, doc.job
    var = parse_cutter(j.cutter).size_symbol
    cutters = list(dict.fromkeys(short_cutter(c) for c in (j.cutters or [j.cutter])))
    part = ("no part: checked against the stock and the fixtures only" if j.part is None
            else f"part deviation {s.part_deviation:.4f}")
    head = (f"{j.path}: {s.cl_points} poses, {s.move_points} moves ({s.poses_checked} poses "
            f"checked), {len(doc.operations)} operation(s), {j.axis_class}, tolerance up to "
            f"{s.tolerance:.4f} mm ({part}), {s.time_s:.2f} s\n"
            f"cutter{'s' if len(cutters) > 1 else ''} (mm): {', '.join(cutters)}; job in "
            f"{j.units}\n"
            f"{'FINDINGS' if s.status == 'findings' else 'clean'}: {_counts_line(s.counts)}")
    if s.counts_cam is not None:
        head += f"\nat the CAM's own angles: {_counts_line(s.counts_cam)}"
    if doc.orientation is not None:
        o = doc.orientation
        greedy = ("" if o.greedy_total_rotation is None
                  else f"greedy {o.greedy_total_rotation:.1f} deg, ")
        head += (f"\nrotary motion: chosen {o.dp_total_rotation:.1f} deg (shortest path), "
                 f"{greedy}CAM {o.original_total_rotation:.1f} deg; {o.infeasible_points} "
                 "points with no feasible B")
    head += "\n" + stock_line(doc.stock, doc.job.stated_stock)
    if doc.machine is not None:
        head += "\n" + machine_line(doc.machine)
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
                fixed(op.b_written[0], 3) if op.b_written[0] == op.b_written[1]
                else f"{fixed(op.b_written[0], 1)}..{fixed(op.b_written[1], 1)}")
            t.add_row(str(op.index + 1), short_cutter(op.cutter), op.axis_class,
                      op.handling, b, f"{op.tolerance:.4f}",
                      str(findings_in(c)))
        out.append(t)
    if s.worst:
        t = Table(title="worst findings")
        for col in ("line", "pose", "verdict", "depth (mm)", "B", "where (mm)"):
            t.add_column(col)
        for f in s.worst:
            where = f.point if f.point is not None else f.tip
            t.add_row(str(f.line), "CL" if f.kind == "cl" else f.kind, f.verdict,
                      f"{f.depth or 0:.4f}", "-" if f.b is None else fixed(f.b, 3),
                      ", ".join(fixed(x, 3) for x in where))
        out.append(t)
    if j.part is None:
        return out
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


def record(doc, store_path: Path | None = None) -> None:
    """Record the check in the results store (`store_path`, default PATHCHECK_STORE or config
    store.path); a store problem (locked, a full disk) is a one-line note on stderr, not a
    failure."""
    from checker.errors import PathcheckError
    from checker.store import ResultsStore

    try:
        with ResultsStore(store_path) as store:
            store.record_job(doc, elapsed_s=doc.summary.time_s, source="cli")
    except PathcheckError as err:
        click.echo(f"pathcheck: note: not recorded in the results store: {err}", err=True)


@click.command()
@click.argument("job", type=click.Path(dir_okay=False, path_type=Path))
@opt.part_option(help="part file, in the frame of the CL file (default: the file beside JOB "
                 "with the same stem)")
@opt.cutter_option(help='override the cutter, "CUTTER/..." in the job\'s units unless --units')
@opt.units_option()
@opt.tool_option()
@opt.tool_library_option()
@opt.config_option()
@opt.json_option()
@opt.output_option("write the corrected 4-axis G-code here (atomically)")
@opt.machine_option()
@click.option("--b-range", "b_range", default=None, metavar="LO:HI",
              help="B range searched for the best table angle, degrees (default from config)")
@click.option("--reorient", is_flag=True,
              help="re-orient the tool: a 3-axis operation gets a table angle B per cutting "
                   "pose (run it on the 4-axis machine; a 4-axis operation's B is planned with "
                   "or without this flag), a multi-axis (5-axis) operation a tool axis per "
                   "contact pose by --strategy; where that does not remove the findings the "
                   "CAM's angles are written")
@click.option("--strategy", type=click.Choice(["allowable", "contact-order"]),
              default="allowable", show_default=True,
              help="with --reorient, the planner of multi-axis operations: allowable (inside "
                   "each pose's feasible set, nearest the CAM's axis, least turn) or "
                   "contact-order (flat-end and bull-nose finishing at the highest-order "
                   "contact, Liu et al.); 3-axis and 4-axis operations get their B either way")
@click.option("--part-transform", default=None, metavar="RX,RY,RZ,DX,DY,DZ|3x4",
              help="place a part exported in another frame: rotations about X, Y, Z (degrees) "
                   "then an offset (mm), or a 3x4 matrix row by row")
@opt.store_option()
@click.option("--no-store", is_flag=True, help="do not record this check in the results store")
@click.option("--on-findings", type=click.Choice(["refuse", "stop", "comment"]),
              default="refuse", show_default=True,
              help="posting (-o) when the program as written has gouges, interference, holder "
                   "hits, crashes, machine collisions or points without a feasible B: refuse "
                   "(write nothing, exit 1), stop (a comment and an optional stop M01 before "
                   "each offending move) or comment (a comment before each)")
@click.option("--no-check", is_flag=True,
              help="post -o without checking (no part read); the program's header says NOT "
                   "CHECKED")
@opt.stock_options
@view_option
@opt.machine_check_options
def check(job, part_path, cutter_text, units, tool_name, tool_library, config_path, json_out,
          output, machine, b_range, reorient, strategy, part_transform, store_path, no_store,
          on_findings, no_check, stock_text, fixtures, stock_resolution, stock_out, deviation_out,
          leave, view_out, machine_check, machine_clearance) -> None:
    """Check JOB (APT-CL or NX CLSF) against its part: allowable cutter, verdict and margin at
    every CC point.

    \b
    pathcheck samples/mould/mould.apt
    pathcheck samples/mould/mould.apt --json out/mould.json
    pathcheck samples/mould/mould.apt --json - 2>/dev/null   # the document alone on stdout
    pathcheck job.apt --machine linuxcnc-xyzac-trt --machine-check   # the machine's solids too
    """
    from checker.check import check_job
    from checker.check.inputs import job_machine
    from checker.check.options import CheckOptions
    from checker.commands.outputs import prepare_outputs
    from checker.errors import PathcheckError

    if strategy != "allowable" and not reorient:
        raise PathcheckError(f"--strategy {strategy} plans the re-orientation: add --reorient",
                             code="usage")
    if not job.is_file():
        raise PathcheckError("job file not found: expected an existing CL file", path=job)
    store = None if no_store else opt.store_of(store_path, config_path)
    from checker.geometry import find_part_beside

    prepare_outputs([("-o", output, "G-code"), ("--json", json_out, "results JSON"),
                     ("--view", view_out, "3-D view")],
                    job_inputs(job, part_path or find_part_beside(job), config_path,
                               tool_library, machine, store, no_check or no_store))
    cutter = opt.cutter_choice(cutter_text, tool_name, tool_library)
    stock = opt.stock_request(stock_text, fixtures, stock_resolution, stock_out,
                               deviation_out, leave)
    if no_check:
        if machine_check or machine_clearance is not None:
            raise PathcheckError("--no-check posts without checking: remove --machine-check",
                                 code="usage")
        post_without_check(job, output, cutter, machine, config_path, part_path, json_out, units)
        return
    # the machine of a machine check is loaded first, so that one it cannot make is refused
    # before any work, and handed to the check as loaded
    if machine_check or machine_clearance is not None:
        machine = job_machine(job, machine)
    clearance = opt.machine_clearance_of(machine_check, machine_clearance, machine)
    from checker.check.posting import PostRefusedError
    from checker.errors import printable

    if not no_store:
        opt.open_store(store)
    try:
        doc = check_job(job, part_path, CheckOptions(
            cutter=cutter, config=config_path, output=output, machine=machine,
            b_range=parse_b_range(b_range), reorient=reorient, strategy=strategy,
            part_transform=part_transform, cutter_units=units, on_findings=on_findings,
            stock=stock, machine_clearance=clearance))
    except PostRefusedError as refused:
        write_after_check(view_out, refused.document, cutter=cutter, stock=stock,
                          config=config_path)
        try:
            finish(refused.document, json_out, store=not no_store, store_path=store)
        finally:
            click.echo(f"pathcheck: {printable(str(output))}: not written: {refused}; give "
                       "--on-findings stop (an optional stop M01 before each) or comment to "
                       "write it", err=True)
        sys.exit(1)
    except PathcheckError as err:
        checked = getattr(err, "document", None)  # the check ran, its program was not written
        if checked is not None and not no_store:
            record(checked, store)
        raise
    write_after_check(view_out, doc, cutter=cutter, stock=stock, config=config_path)
    finish(doc, json_out, store=not no_store, store_path=store)


def job_inputs(job: Path, part_path: Path | None, config_path: Path | None,
               tool_library: Path | None, machine: str | None, store: Path | None,
               no_store: bool) -> list[tuple[str, Path | None]]:
    """The files a check reads (and the store it records in), as `prepare_outputs` names them:
    the job, its part, the config, the tool library, a machine file and the results store."""
    from checker.config import default_config

    files: list[tuple[str, Path | None]] = [
        ("the job file", job), ("the part", part_path),
        ("--config", config_path), ("--tool-library", tool_library)]
    if machine is not None and Path(machine).is_file():
        files.append(("--machine", Path(machine)))
    if not no_store:
        where = store if store is not None else default_config().store.resolved_path()
        files.append(("the results store", where))
    return files


def post_without_check(job: Path, output: Path | None, cutter, machine: str | None,
                       config_path: Path | None, part_path: Path | None,
                       json_out: Path | None, units: str | None) -> None:
    """`--no-check`: post JOB to -o without reading a part; nothing is recorded."""
    from checker.check.posting import post_unchecked
    from checker.errors import PathcheckError

    for given, name in ((output is None, "expected -o FILE"),
                        (part_path is not None, "no part is read: remove --part"),
                        (json_out is not None, "there are no results: remove --json")):
        if given:
            raise PathcheckError(f"--no-check posts without checking: {name}", code="usage")
    path = post_unchecked(job, output, cutter=cutter, machine=machine, config=config_path,
                          cutter_units=units)
    click.echo(f"G-code written: {path} (NOT CHECKED: no part was read)")


def finish(doc, json_out: Path | None, *, store: bool, store_path: Path | None = None) -> None:
    """Print the summary (stderr when `--json -` owns stdout), record the check in `store_path`,
    write the JSON (a file that cannot be written is exit 2, the check recorded all the same);
    exit 1 when there are findings."""
    from checker.commands.terminal import text_console

    console = text_console(stderr=opt.json_to_stdout(json_out))
    for item in summary_view(doc):
        console.print(item)
    if store:
        record(doc, store_path)
    if json_out is not None:
        opt.write_json(json_out, doc.model_dump_json(indent=1), what="results JSON")
    if doc.summary.status == "findings":
        sys.exit(1)
