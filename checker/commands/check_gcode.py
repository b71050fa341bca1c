"""`pathcheck check-gcode PROG.nc --machine NAME [--part PART] [--cutter "CUTTER/..."]`: read an
existing program in the machine's dialect, apply the machine kinematics back into the part frame,
report its moves and the machine checks (travel, rotary limits and wraps, singular passages, axis
feeds), and with --part and --cutter check it like a CL job. Exit 1 on findings of either."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click
import numpy as np

from checker.commands import options as opt
from checker.commands.terminal import note
from checker.commands.view import view_option, write_after_check
from checker.progress import step


def assumed_units(moves, given: str | None, machine) -> None:
    """A program that states no units is read in `--units`, else in the units its machine file
    states, with a note naming the file and the unit (`terminal.note`: shown unless the command
    ends with an input error); neither: a PathcheckError."""
    if moves.units_stated:
        return
    from checker.errors import PathcheckError, printable
    from checker.postproc.dialects import get_dialect

    codes = "/".join(f"G{c}" for c in get_dialect(moves.dialect).units_codes)
    if given is None and "units" not in machine.model_fields_set:
        raise PathcheckError(
            f"the program states no units (no {codes}) and machine {machine.name} gives none: "
            "expected --units mm|inch", path=moves.path, code="usage")
    source = "--units" if given else f"the units of machine {machine.name}"
    note(f"{printable(str(moves.path))} states no units (no {codes}): read in {moves.units}, "
         f"{source}")


@click.command()
@click.argument("program", type=click.Path(dir_okay=False, path_type=Path))
@opt.machine_option(help="a shipped machine's name or a machine TOML file [default: fanuc-hmc]")
@click.option(
    "--dialect", default=None,
    help="override the machine's dialect (fanuc, haas, linuxcnc, siemens, heidenhain, millplus)",
)
@click.option(
    "--units", type=click.Choice(["mm", "inch"]), default=None,
    help="units of a program that states none (no G20/G21) [default: the machine file's]"
)
@click.option(
    "--block-delete", type=click.Choice(["on", "off"]), default="on", show_default=True,
    help="the block-delete switch: on skips the blocks starting with '/', off runs them",
)
@opt.part_option()
@opt.cutter_option(help='cutter, e.g. "CUTTER/6,3", in the program\'s units (G20/G21, --units)')
@opt.tool_option()
@opt.tool_library_option()
@opt.config_option()
@opt.json_option("the program's summary (with --part and --cutter: the results document)")
@opt.store_option()
@click.option("--no-store", is_flag=True, help="do not record this check in the results store")
@opt.stock_options
@view_option
@opt.machine_check_options
def check_gcode(program: Path, machine, dialect, units, block_delete, part_path, cutter_text,
                tool_name, tool_library, config_path, json_out, store_path, no_store,
                stock_text, fixtures, stock_resolution, stock_out, deviation_out, leave,
                view_out, machine_check, machine_clearance) -> None:
    """Read PROGRAM (G-code) for a machine, bring its moves back into the part frame and, with
    --part and --cutter, check them like `pathcheck JOB.apt` (exit 1 on findings).

    \b
    pathcheck check-gcode prog.nc --machine fanuc-hmc
    pathcheck check-gcode prog.ngc --machine linuxcnc-hmc --json out.json
    pathcheck check-gcode boat.ngc --machine linuxcnc-xyzac-trt --part boat.stl --cutter CUTTER/10
    pathcheck check-gcode boat.ngc --machine linuxcnc-xyzac-trt --cutter CUTTER/10 --machine-check
    """
    from checker.commands.check import job_inputs
    from checker.commands.outputs import prepare_outputs
    from checker.cutter import parse_cutter_in
    from checker.errors import PathcheckError
    from checker.postproc.describe import describe_program, format_program_summary
    from checker.postproc.machine import load_machine
    from checker.postproc.reader import CYCLE, PROGRAMMED, read_gcode
    from checker.postproc.replay import part_motions

    mach = load_machine(machine)
    cutter = opt.cutter_choice(cutter_text, tool_name, tool_library)
    stock = opt.stock_request(stock_text, fixtures, stock_resolution, stock_out,
                               deviation_out, leave)
    if part_path is not None and not part_path.is_file():
        raise PathcheckError(
            "part file not found: expected an existing file", path=part_path, code="part"
        )
    if stock.asked and cutter is None:
        raise PathcheckError("--stock and --fixture check the program's tool against them: "
                             "expected --cutter or --tool (a G-code program does not say its "
                             "cutter)", code="usage")
    clearance = opt.machine_clearance_of(machine_check, machine_clearance, mach)
    checking = cutter is not None and (part_path is not None or stock.asked
                                       or clearance is not None)
    if view_out is not None and not checking:
        raise PathcheckError("--view shows a check: give --cutter with --part or --stock",
                             code="usage")
    store = opt.store_of(store_path, config_path) if checking and not no_store else None
    prepare_outputs([("--json", json_out, "results JSON"), ("--view", view_out, "3-D view")],
                    job_inputs(program, part_path, config_path, tool_library, machine, store,
                               not checking or no_store))
    if checking and not no_store:
        opt.open_store(store)
    with step("read the program"):
        moves = read_gcode(program, dialect or mach.dialect, units=units or mach.units,
                           block_delete=block_delete == "on")
    if not np.isin(moves.kind, (PROGRAMMED, CYCLE)).any():
        raise PathcheckError(f"no motion: expected G0/G1/G2/G3 moves or drilling cycles, found "
                             f"none in {moves.blocks} blocks", path=program, code="gcode")
    assumed_units(moves, units, mach)
    if isinstance(cutter, str):  # read in the program's units (G20/G21, else --units)
        cutter = parse_cutter_in(cutter, moves.units)
    with step("the moves in the part frame"):
        motions = part_motions(moves, mach)
        doc = describe_program(moves, motions, mach)
    opt.say(format_program_summary(doc), json_out=json_out)
    if not checking:
        opt.say("give --cutter and --part (gouges and interference), --stock/--fixture (crashes "
                "into the stock and the fixtures) or --machine-check (the machine's solids) to "
                "check the program",
                json_out=json_out)
        if json_out is not None:
            opt.write_json(json_out, json.dumps(doc, indent=2), what="program JSON")
        if doc["machine_checks"]:
            sys.exit(1)
        return
    from checker.check import check_toolpath
    from checker.check.options import CheckOptions
    from checker.commands.check import finish
    from checker.postproc.replay import toolpath_of

    toolpath = toolpath_of(motions, path=program, units=moves.units, cutter=cutter)
    result = check_toolpath(toolpath, part_path, CheckOptions(
        cutter=cutter, machine=mach, config=config_path, stock=stock,
        machine_clearance=clearance))
    write_after_check(view_out, result, toolpath=toolpath, cutter=cutter, stock=stock,
                      config=config_path)
    finish(result, json_out, store=not no_store, store_path=store)
    if doc["machine_checks"]:
        sys.exit(1)
