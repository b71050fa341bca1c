"""The real 5-axis programs of ../shared/realdata read with their machine files: no error, and
per program the blocks, motions, axis ranges and part-frame box (printed); the rotary sign
conventions of the machine files measured on the programs themselves; the machine checks
(Toyoda's G95 feed, the DMU's C swing at the pole)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from checker.cli import main
from checker.postproc.describe import describe_program, format_program_summary
from checker.postproc.machine import load_machine
from checker.postproc.reader import read_gcode
from checker.postproc.replay import part_motions

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata"
PROGRAMS = [
    ("linuxcnc-5axis-gcode/boat-xyzac.ngc", "linuxcnc-xyzac-trt"),
    ("linuxcnc-5axis-gcode/boat-xyzbc.ngc", "linuxcnc-xyzbc-trt"),
    ("linuxcnc-5axis-gcode/impeller-7bl-xyzac.ngc", "linuxcnc-xyzac-trt"),
    ("linuxcnc-5axis-gcode/xyzab-tdr-demo.ngc", "linuxcnc-xyzab-tdr"),
    ("nx-postlib-gcode/DMU70eVo_840D_5axis_BC.ptp", "dmu70evo-840d"),
    ("nx-postlib-gcode/Haas_VF2_TR_5axis_AB.ptp", "haas-vf2-tr"),
    ("nx-postlib-gcode/DMG_DMC160U_MillPlus_5axis.ptp", "dmc160u-millplus"),
]


def _program(rel: str) -> Path:
    path = REAL / rel
    if not path.is_file():
        pytest.skip(f"{path} not present (../shared/realdata is absent)")
    return path


def _read(rel: str, name: str):
    machine = load_machine(name)
    moves = read_gcode(_program(rel), machine.dialect, units=machine.units)
    return machine, moves, part_motions(moves, machine)


@pytest.mark.parametrize(("rel", "name"), PROGRAMS, ids=[Path(p).stem for p, _ in PROGRAMS])
def test_realdata_program_reads_with_its_machine(rel, name, capsys):
    machine, moves, motions = _read(rel, name)
    doc = describe_program(moves, motions, machine)
    with capsys.disabled():
        print("\n" + format_program_summary(doc))
    assert doc["blocks"] > 20 and doc["motions"]["motion"] > 20
    assert doc["points"]["known"] >= 0.9 * doc["points"]["total"]
    for axis in machine.rotary_axes:  # every rotary axis of the machine is used
        lo, hi = doc["axes"][axis.name]
        assert hi > lo
    box = np.array(doc["bbox_mm"])
    assert np.isfinite(box).all() and (box[:, 1] > box[:, 0]).all()
    known = motions.known
    assert np.allclose(np.linalg.norm(motions.axis[known], axis=1), 1.0)
    # tool-centre-point programs carry the tips themselves: the box is the X Y Z words' box
    if moves.tcp is not None and moves.tcp.all():
        assert np.allclose(motions.tip[known], motions.xyz[known])


def _tangency(machine, moves) -> float:
    """Mean |t . a| over feed moves that turn a rotary axis: t the direction of the tip path
    in the part frame, a the tool axis. Contouring with the tool normal to the surface keeps it
    near 0; a wrong rotation sense scatters it."""
    pm = part_motions(moves, machine, rotary_step=1e9)  # block ends only
    ok = pm.known & ~pm.rapid
    ok[1:] &= pm.known[:-1]
    d = pm.tip[1:] - pm.tip[:-1]
    length = np.linalg.norm(d, axis=1)
    turn = np.any(np.abs(np.diff(pm.joints, axis=0)) > 0.05, axis=1)
    sel = ok[1:] & (length > 1e-3) & turn
    t = d[sel] / length[sel, None]
    return float(np.abs((t * pm.axis[1:][sel]).sum(axis=1)).mean())


@pytest.mark.parametrize(("rel", "name"), [PROGRAMS[i] for i in (0, 1, 4, 5, 6)],
                         ids=["boat-xyzac", "boat-xyzbc", "dmu70evo", "haas-vf2-tr", "dmc160u"])
def test_rotation_senses_measured_on_the_programs(rel, name, capsys):
    """The shipped directions give the smallest mean |t . a| of the four sign choices (LinuxCNC
    boats: they agree with the kinematics modules; NX posts: 'standard' tables turn the part
    left-handed about the post's vector)."""
    machine, moves, _ = _read(rel, name)
    scores = {}
    for signs in itertools.product([1, -1], repeat=len(machine.rotary_axes)):
        flipped = machine.with_options(rotary_axes=[
            {"direction": tuple(s * np.array(a.direction))}
            for s, a in zip(signs, machine.rotary_axes, strict=True)])
        scores[signs] = _tangency(flipped, moves)
    with capsys.disabled():
        print(f"\n{name}: mean |t.a| by sign choice {scores}")
    shipped = scores[(1,) * len(machine.rotary_axes)]
    assert shipped == min(scores.values())
    assert shipped < 0.3


def test_toyoda_g95_feed_is_per_revolution_and_flagged(capsys):
    """G95 F9.8425 (inch/rev) at S1000 is 250 m/min as the control means it: a machine-check
    finding naming the line and G95, exit 1; not an error."""
    path = _program("nx-postlib-gcode/Toyoda_FH55_horizontal_B.ptp")
    with pytest.raises(SystemExit) as ex:
        main(["check-gcode", str(path), "--machine", "fanuc-hmc"])
    assert ex.value.code == 1
    out = capsys.readouterr().out
    assert "249999.5 mm/min" in out and "G95" in out and "feed: line 89" in out


def test_dmu_c_swing_at_the_pole_is_a_singular_passage():
    machine, moves, motions = _read("nx-postlib-gcode/DMU70eVo_840D_5axis_BC.ptp",
                                    "dmu70evo-840d")
    checks = describe_program(moves, motions, machine)["machine_checks"]
    singular = [c for c in checks if c["check"] == "singular"]
    assert singular and singular[0]["line"] == 480  # C185.644 -> C9.03 with B 0 -> 0.387
