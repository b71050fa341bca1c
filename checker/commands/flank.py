"""`pathcheck flank JOB.apt --part PART [--cutter ...] [--optimise] [-o improved.apt]
[--json FILE|-] [--picture FILE.png]`: the envelope of a flank-milling pass against its design
surface (Gong and Wang 2009), per pose and per move the largest overcut and undercut, and the
least-squares improved path."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from checker.commands import options as opt
from checker.errors import PathcheckError


def _mm(x: float | None) -> str:
    return "     -" if x is None else f"{x:.4f}"


def _text(doc, worst: int) -> list[str]:
    """The human lines: per pose and the worst moves of the final path, the summaries."""
    final = doc.after or doc.before
    out = [f"flank pass of {len(final.poses)} poses against surface {doc.surface} of "
           f"{doc.part}; {doc.cutter}; error along the envelope's normal, mm, "
           "overcut > 0 into the material", "pose  line  overcut  undercut"]
    out += [f"{p.index:4d} {p.line:5d}  {_mm(p.max_overcut)}   {_mm(p.max_undercut)}"
            for p in final.poses]
    out.append("worst moves (line -> line: overcut, undercut):")
    out += [f"  {m.from_line} -> {m.to_line}: {_mm(m.max_overcut)}, {_mm(m.max_undercut)}"
            for m in final.worst_moves[:worst]]
    for name, r in (("before", doc.before), ("after", doc.after)):
        if r is not None:
            s = r.summary
            out.append(f"{name}: max overcut {s.max_overcut:.4f} mm, max undercut "
                       f"{s.max_undercut:.4f} mm, rms {s.rms:.4f} mm over {s.points} points")
    out.append(f"status: {doc.status} (tolerance {doc.tolerance:g} mm)")
    return out


@click.command()
@click.argument("job", type=click.Path(dir_okay=False, path_type=Path))
@opt.part_option(help="part file with the design surface (geomdl JSON/YAML, STEP, IGES), in "
                 "the frame of the CL file [default: the part beside JOB]")
@opt.cutter_option(help='cutter, e.g. "CUTTER/10,0,5,0,0,3,40"; in the job\'s units unless '
                   "--units [default: the pass's CUTTER]")
@opt.units_option()
@opt.tool_option()
@opt.tool_library_option()
@opt.config_option()
@click.option("--surface", "surface", type=int, default=None,
              help="index of the design surface in the part [default: the one the pass flanks]")
@click.option("--tolerance", type=float, default=None,
              help="mm of overcut or undercut allowed [default: config check.depth_tolerance]")
@click.option("--heights", "count", type=click.IntRange(3, 400), default=25, show_default=True,
              help="heights along the cutter's side where the grazing curve is sampled")
@click.option("--optimise", is_flag=True, help="adjust the tool axis trajectory by least "
              "squares (Gong and Wang 2009) and judge the improved path")
@opt.output_option("write the improved path (with --optimise) as an APT-CL file")
@opt.json_option("the flank document")
@click.option("--picture", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="write the error map over the design surface's (u, v) as a PNG")
def flank(job, part_path, cutter_text, units, tool_name, tool_library, config_path, surface,
          tolerance, count, optimise, output, json_out, picture) -> None:
    """Flank milling: the envelope of the cutter along the pass of JOB, its error to the
    design surface along the envelope's normal (overcut > 0), per pose, per move and as a map;
    with --optimise the least-squares improved tool axis trajectory. Exit 1 when the final
    path's overcut or undercut exceeds the tolerance.

    \b
    pathcheck flank samples/flank/hypar.apt --part samples/flank/hypar.json
    pathcheck flank samples/flank/hypar.apt --optimise -o better.apt --picture map.png
    """
    from checker.apt import read_cl
    from checker.commands.outputs import prepare_outputs
    from checker.config import load_config
    from checker.cutter import parse_cutter_in
    from checker.flank.path import replaced_apt
    from checker.flank.run import flank_job
    from checker.geometry import find_part_beside, load_part

    if output is not None and not optimise:
        raise PathcheckError("-o writes the improved path: give --optimise", code="usage")
    prepare_outputs([("-o", output, "APT file"), ("--json", json_out, "flank JSON"),
                     ("--picture", picture, "picture")],
                    [("the job file", job), ("the part", part_path or find_part_beside(job)),
                     ("--config", config_path), ("--tool-library", tool_library)])
    config = load_config(config_path)
    toolpath = read_cl(job, require_cutter=cutter_text is None and tool_name is None)
    chosen = opt.cutter_choice(cutter_text, tool_name, tool_library)
    if isinstance(chosen, str):
        chosen = parse_cutter_in(chosen, units or toolpath.units)
    if part_path is None:
        part_path = find_part_beside(job)
        if part_path is None:
            raise PathcheckError("give --part: no part file beside the job", path=job)
    part = load_part(part_path, geometry=config.geometry)
    run = flank_job(toolpath, part, chosen, str(part_path),
                    tolerance=config.check.depth_tolerance if tolerance is None else tolerance,
                    surface=surface, count=count, optimise=optimise)
    doc = run.document
    if output is not None:
        from checker.atomic import make_parent, write_file

        make_parent(output, "APT file")
        write_file(output, replaced_apt(toolpath, run.lines, run.tips, run.axes),
                   what="APT file")
        doc.optimisation.written = str(output)
    if picture is not None:
        from checker.flank.picture import draw_error_map

        maps = [("before", doc.before.map)] + ([("after", doc.after.map)] if doc.after else [])
        draw_error_map(maps, picture, f"{Path(job).name}: {doc.cutter}")
    for line in _text(doc, 10):
        opt.say(line, json_out=json_out)
    if json_out is not None:
        opt.write_json(json_out, doc.model_dump_json(indent=1), what="flank JSON")
    sys.exit(0 if doc.status == "ok" else 1)

