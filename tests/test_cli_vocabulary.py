"""One vocabulary of options across the commands, read from the click tree itself (every
command, a group's subcommands included), and what the shared options do on real runs:
`--json -` is the JSON document alone on stdout, `--cutter` follows the job's units, the
summary names every cutter and the CAM's real rotary motion, shell completion is a script."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from checker.cli import cli
from checker.commands.options import EXIT_CODES

REPO = Path(__file__).resolve().parents[1]

# the commands that take each kind of input or output (the vocabulary's "where")
TAKES_PART = {"check", "check-gcode", "allowable", "map", "flank"}
TAKES_CUTTER = {"check", "check-gcode", "allowable", "map", "flank"}
USES_STORE = {"check", "check-gcode", "batch", "report", "serve", "store prune"}
READS_CONFIG = {"check", "check-gcode", "allowable", "batch", "call", "report", "serve",
                "store prune", "flank", "view"}
HAS_JSON = {"check", "check-gcode", "allowable", "info", "flank"}
HAS_OUTPUT = {"check", "map", "report", "call", "flank", "view"}
# spellings that another name replaced: none may be shown in any help
RETIRED = {"--out", "--tools", "--json-out", "--part-file", "--gcode", "--cutters"}


def _commands() -> dict[str, click.Command]:
    """Every leaf command by its full name ("store prune"), loaded as `pathcheck` loads it."""
    ctx = click.Context(cli)
    out: dict[str, click.Command] = {}

    def walk(group: click.Group, prefix: str) -> None:
        for name in group.list_commands(ctx):
            cmd = group.get_command(ctx, name)
            if isinstance(cmd, click.Group):
                walk(cmd, f"{prefix}{name} ")
            else:
                out[f"{prefix}{name}"] = cmd

    walk(cli, "")
    return out


COMMANDS = _commands()


def _shown(cmd: click.Command) -> dict[str, click.Option]:
    """The option names a command's help shows (old spellings kept as hidden aliases are
    not) -> the option."""
    return {name: p for p in cmd.params if isinstance(p, click.Option) and not p.hidden
            for name in p.opts + p.secondary_opts
            if name not in getattr(p, "hidden_names", ())}


def test_the_tree_has_every_command():
    assert set(COMMANDS) == {"allowable", "batch", "call", "check", "check-gcode", "flank",
                             "info", "map", "report", "serve", "store prune", "view", "warm"}


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_speaks_the_shared_vocabulary(name):
    cmd = COMMANDS[name]
    shown = _shown(cmd)
    assert {"-q", "--quiet", "-v", "--verbose"} <= set(shown)
    assert not RETIRED & set(shown), RETIRED & set(shown)
    assert not [p for p in cmd.params if isinstance(p, click.Argument)
                and p.name in ("part_path", "part", "cutter_text")], "part/cutter as argument"
    expect = {"--part": TAKES_PART, "--cutter": TAKES_CUTTER, "--tool": TAKES_CUTTER,
              "--tool-library": TAKES_CUTTER, "--store": USES_STORE, "--config": READS_CONFIG,
              "--json": HAS_JSON, "--output": HAS_OUTPUT}
    for option, where in expect.items():
        assert (option in shown) == (name in where), (name, option)
    if "--output" in shown:
        assert shown["--output"] is shown["-o"]
    if "--json" in shown:  # a file, or '-' for stdout: never a flag
        p = shown["--json"]
        assert not p.is_flag and p.type.allow_dash
    for option in ("--part", "--store", "--config", "--tool-library"):
        if option in shown:  # a file, never a folder
            assert isinstance(shown[option].type, click.Path) and not shown[option].type.dir_okay


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_help_ends_with_the_exit_codes(name):
    run = CliRunner().invoke(cli, [*name.split(), "--help"], terminal_width=100)
    assert run.exit_code == 0, run.output
    text = " ".join(run.output.split())
    assert " ".join(EXIT_CODES.replace("\b", "").split()) in text
    assert "0 clean, 1 findings, 2 bad input" in text
    assert not [w for w in RETIRED if re.search(rf"(?<![\w-]){w}\b(?!-)", text)]


def test_quiet_and_verbose_together_is_a_usage_error():
    run = CliRunner().invoke(cli, ["info", "x.apt", "-q", "-v"])
    assert run.exit_code == 2 and "give --quiet or --verbose, not both" in run.output


def _env(tmp_path: Path) -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(REPO), PATHCHECK_STORE=str(tmp_path / "r.sqlite"),
                PATHCHECK_LOG_DIR=str(tmp_path / "logs"))


def _pathcheck(args: list[str], tmp_path: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "checker.cli", *args], cwd=tmp_path,
                          env={**_env(tmp_path), **env}, capture_output=True, text=True,
                          timeout=300)


@pytest.fixture(scope="module")
def floor_job(tmp_path_factory) -> Path:
    """A 40 x 40 mm floor (z = 0) and a two-tool job: a ball D6 along the floor (3-axis, B 0),
    then a ball D4 indexed to B = -90 (axis +x) beyond the floor's end: the CAM's program turns
    the table by 90 degrees once."""
    from geomdl import BSpline, exchange, multi

    folder = tmp_path_factory.mktemp("floor")
    s = BSpline.Surface()
    s.degree_u = s.degree_v = 1
    s.ctrlpts_size_u = s.ctrlpts_size_v = 2
    s.ctrlpts = [[0, -10, 0], [0, 30, 0], [40, -10, 0], [40, 30, 0]]
    s.knotvector_u = s.knotvector_v = [0, 0, 1, 1]
    exchange.export_json(multi.SurfaceContainer([s]), str(folder / "floor.json"))
    (folder / "floor.apt").write_text(
        "PARTNO/FLOOR\nUNITS/MM\nCUTTER/6,3\nLOADTL/1\nFEDRAT/500,MMPM\nGOTO/10,0,0\n"
        "GOTO/30,0,0\nGOTO/30,0,20\nCUTTER/4,2\nLOADTL/2\nGOTO/60,0,10,1,0,0\n"
        "GOTO/60,10,10,1,0,0\nEND\nFINI\n")
    return folder / "floor.apt"


def test_json_dash_is_the_document_alone_and_the_summary_names_every_cutter(floor_job,
                                                                             tmp_path):
    run = _pathcheck([str(floor_job), "--reorient", "--no-store", "--json", "-"], tmp_path)
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)  # nothing but the document on stdout
    assert doc["job"]["cutters"] == ["CUTTER/6.0,3.0,0.0,3.0,0.0,0.0,0.0",
                                     "CUTTER/4.0,2.0,0.0,2.0,0.0,0.0,0.0"]
    # the CAM's program indexes 0 -> -90: 90 degrees of rotary motion, written or not
    assert doc["orientation"]["original_total_rotation"] == pytest.approx(90.0, abs=1e-9)
    assert [o["b_written"] for o in doc["operations"]][1] == pytest.approx([-90.0, -90.0])
    summary = run.stderr.splitlines()
    assert "cutters (mm): CUTTER/6,3,0,3, CUTTER/4,2,0,2; job in mm" in summary
    assert any(line.startswith("rotary motion:") and "CAM 90.0 deg" in line for line in summary)


@pytest.mark.parametrize("command", sorted(HAS_JSON))
def test_json_dash_puts_only_the_document_on_stdout(command, floor_job, tmp_path):
    """Every command with a JSON document: `--json -` is that document alone on stdout (the
    text, if any, on stderr), and the same document as `--json FILE`."""
    (tmp_path / "p.nc").write_text("G21 G90\nG0 X0 Y0 Z10\nG1 X10 Y0 Z5 F200\nM30\n")
    (tmp_path / "cc.csv").write_text("x,y,z,nx,ny,nz\n20,10,0,0,0,1\n")
    part = str(floor_job.parent / "floor.json")
    args = {"check": [str(floor_job), "--no-store"], "info": ["info", str(floor_job)],
            "check-gcode": ["check-gcode", "p.nc"],
            "allowable": ["allowable", "--part", part, "--cc", "cc.csv", "--cutter",
                          "CUTTER/6,3"],
            "flank": ["flank", str(REPO / "samples/flank/hypar.apt"), "--part",
                      str(REPO / "samples/flank/hypar.json"), "--heights", "5",
                      "--tolerance", "0.1"]}[command]
    dash = _pathcheck([*args, "--json", "-"], tmp_path)
    assert dash.returncode == 0, dash.stderr
    doc = json.loads(dash.stdout)
    to_file = _pathcheck([*args, "--json", "doc.json"], tmp_path)
    assert to_file.returncode == 0 and to_file.stdout.strip()  # the text is on stdout then
    if command != "info":  # the same text, on stderr with '-' (times aside)
        def text(t: str) -> str:
            return re.sub(r"\d+\.\d+ s\b", "T", t).strip()

        assert text(to_file.stdout) == text(dash.stderr)
    again = json.loads((tmp_path / "doc.json").read_text())
    for volatile in ("summary", "timing"):  # times differ between two runs
        doc.pop(volatile, None), again.pop(volatile, None)
    assert again == doc


def test_info_json_dash_and_json_file(floor_job, tmp_path):
    dash = _pathcheck(["info", str(floor_job), "--json", "-"], tmp_path)
    assert dash.returncode == 0 and dash.stderr == ""
    doc = json.loads(dash.stdout)
    assert doc["totals"]["operations"] == 2
    to_file = _pathcheck(["info", str(floor_job), "--json", "info.json"], tmp_path)
    assert to_file.returncode == 0 and "2 operation(s)" in to_file.stdout
    assert json.loads((tmp_path / "info.json").read_text()) == doc


def test_the_cutter_is_read_in_the_jobs_units(floor_job, tmp_path):
    """An inch job (the same floor path in inches): CUTTER/0.25 is a quarter inch, 6.35 mm;
    --units mm reads the same words as 0.25 mm."""
    inch = tmp_path / "floor.apt"
    inch.write_text("PARTNO/FLOOR\nUNITS/INCHES\nCUTTER/0.25,0.125\nLOADTL/1\n"
                    "FEDRAT/20,IPM\nGOTO/0.4,0,0\nGOTO/1.2,0,0\nEND\nFINI\n")
    part = floor_job.parent / "floor.json"
    for extra, d in (([], 6.35), (["--units", "mm"], 0.25)):
        run = _pathcheck([str(inch), "--part", str(part), "--cutter", "CUTTER/0.25",
                          "--no-store", "--json", "-", *extra], tmp_path)
        assert run.returncode == 0, run.stderr
        job = json.loads(run.stdout)["job"]
        assert job["units"] == "inch"
        assert float(job["cutter"].removeprefix("CUTTER/").split(",")[0]) == pytest.approx(d)
        assert f"cutter (mm): CUTTER/{d:g}" in run.stderr and "job in inch" in run.stderr


def test_verbose_prints_each_step_with_its_time_when_piped(floor_job, tmp_path):
    run = _pathcheck([str(floor_job), "--no-store", "-v"], tmp_path)
    assert run.returncode == 0, run.stderr
    steps = run.stderr.splitlines()
    names = list(dict.fromkeys(line.rsplit(":", 1)[0] for line in steps))  # a step may recur
    assert names == ["pathcheck: read the CL file", "pathcheck: load the part",
                     "pathcheck: triangulate the part", "pathcheck: check along the moves",
                     "pathcheck: plan and check the program",
                     "pathcheck: advice at the cutting poses"], steps
    assert all(line.endswith(" s") and float(line.rsplit(":", 1)[1][:-2]) >= 0
               for line in steps)


def test_shell_completion_is_a_bash_script(tmp_path):
    run = _pathcheck([], tmp_path, _PATHCHECK_COMPLETE="bash_source")
    assert run.returncode == 0, run.stderr
    assert "_pathcheck_completion()" in run.stdout and "complete -o" in run.stdout
    words = _pathcheck([], tmp_path, _PATHCHECK_COMPLETE="bash_complete",
                       COMP_WORDS="pathcheck map --tool", COMP_CWORD="2")
    assert "plain,--tool-library" in words.stdout.splitlines()
