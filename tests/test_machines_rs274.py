"""LinuxCNC's own interpreter (`rs274` from Debian's linuxcnc-uspace, installed by
tools/test-setup.sh) accepts the LinuxCNC posts of every machine kind, with and without TCP
kinematics (M428/M429 remapped as LinuxCNC's 5-axis configurations do), and its canonical moves
are the positions our reader reads, block by block; the same for the realdata LinuxCNC programs.
Skips where rs274 is not installed."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from checker.postproc.machine import load_machine
from checker.postproc.post import post_program
from checker.postproc.reader import read_gcode_text
from tests.test_machines_kinds import KINDS, five_axis_path, four_axis_path

RS274 = shutil.which("rs274")
pytestmark = pytest.mark.skipif(
    RS274 is None, reason="LinuxCNC's rs274 is not installed (tools/test-setup.sh installs "
    "Debian's linuxcnc-uspace where it can)")
REPO = Path(__file__).resolve().parents[1]
REAL = REPO.parent / "shared" / "realdata" / "linuxcnc-5axis-gcode"
_MOVE = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED)\(([^)]*)\)")


@pytest.fixture(scope="module")
def interp(tmp_path_factory):
    """An INI remapping M428/M429 (TCP kinematics on/off) to empty subroutines, a tool table."""
    root = tmp_path_factory.mktemp("rs274")
    (root / "sub").mkdir()
    for code in ("m428", "m429"):
        (root / "sub" / f"{code}.ngc").write_text(f"o<{code}> sub\no<{code}> endsub\nm2\n")
    ini = root / "pathcheck.ini"
    ini.write_text(f"[RS274NGC]\nSUBROUTINE_PATH = {root / 'sub'}\n"
                   "REMAP = M428 modalgroup=10 ngc=m428\nREMAP = M429 modalgroup=10 ngc=m429\n")
    table = root / "tools.tbl"
    table.write_text("".join(f"T{t} P{t} Z0 D10 ;\n" for t in range(1, 10)))
    return ini, table


def run_rs274(interp, program: Path) -> tuple[np.ndarray, np.ndarray]:
    """rs274's canonical moves ``(M, 6)``: X Y Z A B C of every traverse, feed and arc end, and
    which of them come right before a tool change (M6's own move up to the change position,
    which is not in the program when the spindle is already there)."""
    ini, table = interp
    done = subprocess.run([RS274, "-i", str(ini), "-t", str(table), "-g", str(program)],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=120)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    out, m6 = [], []
    lines = done.stdout.splitlines()
    for k, text in enumerate(lines):
        found = _MOVE.search(text)
        if not found:
            continue
        m6.append(k + 1 < len(lines) and "SELECT_TOOL(" in lines[k + 1])
        kind, args = found.groups()
        v = [float(x) for x in args.split(",")]
        if kind == "ARC_FEED":  # first_end, second_end, centre, centre, turn, axis_end, a, b, c
            v = [v[0], v[1], v[5], v[6], v[7], v[8]]  # G17 programs
        out.append(v)
    return np.array(out).reshape(-1, 6), np.array(m6, dtype=bool)


def _compare(run: tuple[np.ndarray, np.ndarray], text: str,
             dialect: str = "linuxcnc") -> tuple[int, float]:
    """Our reader's motion rows (in ``dialect``) against rs274's moves in order: every row of
    ours pairs with the next canonical move at the same position (1e-3; our unknown coordinates
    after G53 match any); rs274 may add moves of its own only before a tool change (M6 moving
    the quill up) or at the start. Returns the rows compared and the largest difference."""
    canon, m6 = run
    ours = read_gcode_text(text, dialect)
    mine = np.c_[ours.xyz, ours.abc]
    j, skipped, errs = 0, [], []
    for i in range(len(mine)):  # a walk over two short sequences, test code only
        while j < len(canon):
            known = np.isfinite(mine[i])
            diff = np.abs(mine[i][known] - canon[j][known])
            if diff.size == 0 or diff.max() < 1e-3:
                errs.append(diff.max() if diff.size else 0.0)
                j += 1
                break
            skipped.append(j)
            j += 1
        else:
            raise AssertionError(f"row {i} (line {ours.line[i]}) {mine[i]} has no rs274 move")
    assert all(m6[k] or canon[k][:3].tolist() == [0.0, 0.0, 0.0] for k in skipped), skipped
    assert len(canon) - j <= 1  # at most M2's own move back is left over
    return int(np.isfinite(ours.xyz).all(axis=1).sum()), float(max(errs))


@pytest.mark.parametrize("tcp", [False, True], ids=["no-tcp", "tcp"])
@pytest.mark.parametrize("name", [*KINDS, "linuxcnc-hmc"])
def test_rs274_accepts_our_linuxcnc_posts(interp, tmp_path, name, tcp, capsys):
    machine = load_machine(name).with_dialect("linuxcnc").with_options(tcp={"enabled": tcp})
    moves = five_axis_path() if len(machine.rotary_axes) == 2 else four_axis_path(machine)
    text = post_program(moves, machine, program_name=f"{name} tcp={tcp}")
    program = tmp_path / "post.ngc"
    program.write_text(text)
    run = run_rs274(interp, program)
    canon = run[0]
    rows, err = _compare(run, text)
    with capsys.disabled():
        print(f"\nrs274 accepts {name} ({machine.kind}, tcp={tcp}): {len(canon)} moves, "
              f"{rows} compared, max |ours - rs274| {err:.1e}")
    assert rows > len(moves) // 2
    assert err < 1e-4  # rs274 prints 4 decimals


def test_rs274_reads_the_fanuc_post_of_the_compressor_as_we_do(interp, tmp_path, capsys):
    """The compressor sample posted for fanuc-hmc (Fanuc dialect, header block included):
    rs274 and our Fanuc reader read the same moves; without the header rs274 reads the very
    same canonical moves (the header is comments only)."""
    from checker.apt import read_cl
    from checker.postproc.post import post_toolpath

    toolpath = read_cl(REPO / "samples" / "compressor" / "compressor.apt")
    program = post_toolpath(toolpath, tmp_path / "compressor.nc", machine="fanuc-hmc")
    text = program.read_text()
    lines = text.splitlines()
    header = lines[2:lines.index("(PATHCHECK VERDICT NOT CHECKED)") + 1]
    assert header[0].startswith("(PATHCHECK ") and header[3].startswith("(TOOL 1 CUTTER/6.0")
    run = run_rs274(interp, program)
    rows, err = _compare(run, text, "fanuc")
    bare = tmp_path / "bare.nc"
    bare.write_text("\n".join(line for line in lines if line not in header) + "\n")
    assert np.array_equal(run_rs274(interp, bare)[0], run[0])
    with capsys.disabled():
        print(f"\nrs274 on the Fanuc post of compressor.apt: {len(run[0])} moves, {rows} "
              f"compared, max |ours - rs274| {err:.1e}")
    assert rows > len(toolpath.motion_arrays().tip) * 0.99
    assert err <= 5e-5  # rs274 prints 4 decimals, the program has 3


@pytest.mark.parametrize("program", ["boat-xyzac.ngc", "boat-xyzbc.ngc", "impeller-7bl-xyzac.ngc"])
def test_rs274_reads_the_realdata_programs_as_we_do(interp, program, capsys):
    path = REAL / program
    if not path.is_file():
        pytest.skip(f"{path} not present (../shared/realdata is absent)")
    run = run_rs274(interp, path)
    canon = run[0]
    rows, err = _compare(run, path.read_text(encoding="latin-1"))
    with capsys.disabled():
        print(f"\nrs274 on {program}: {len(canon)} moves, {rows} compared, max difference "
              f"{err:.1e}")
    assert rows > 0.9 * len(canon) and err < 1e-4
