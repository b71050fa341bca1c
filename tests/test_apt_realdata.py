"""Real CAM output from ../shared/realdata (NX CLSF, SolidWorks CAM APT): totals against the
files' SOURCES notes, info through the CLI, round trip through the writer, arc directions."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from checker.apt import read_cl, write_apt
from checker.apt.toolpath_info import describe_toolpath
from checker.cli import main

NX = "mech491-nx-clsf"
SW = "amorim-solidworkscam-apt"
# file -> (GOTO, GOTO with i,j,k) as stated in the folders' SOURCES.txt (boss: 9814 in the issue)
TOTALS = {
    f"{NX}/APT_Project2.txt": (10585, 5514),
    f"{NX}/APT_Variable_Axis.txt": (348, 329),
    f"{NX}/APT_code.txt": (325, None),
    f"{SW}/boss.apt": (9814, 5751),
    f"{SW}/wall-holes.apt": (1864, 692),
    f"{SW}/Telemecanique-Tilt-Support1.apt": (184, 184),
    f"{SW}/Teste-Metrologia.apt": (454, 326),
    f"{SW}/Sacrifice-Board.apt": (494, 272),
    f"{SW}/RotateThin.apt": (338, None),
    f"{SW}/manufacture3-top.apt": (360, None),
    f"{SW}/Interface-glue.apt": (6311, None),
}


def cl_files(root: Path) -> list[Path]:
    files = sorted((root / NX).glob("APT_*.txt")) + sorted((root / SW).glob("*.apt"))
    assert len(files) == 15, f"expected 7 NX and 8 SolidWorks files, found {len(files)}"
    return files


@pytest.fixture(scope="module")
def toolpaths(realdata):
    return {f"{p.parent.name}/{p.name}": read_cl(p) for p in cl_files(realdata)}


def test_info_json_succeeds_on_every_file(realdata, capsys):
    for p in cl_files(realdata):
        with pytest.raises(SystemExit) as exc:
            main(["info", "--json", "-", str(p)])
        out, err = capsys.readouterr()
        assert exc.value.code == 0, err
        d = json.loads(out)
        want = TOTALS.get(f"{p.parent.name}/{p.name}")
        if want is not None:
            assert d["totals"]["goto"] == want[0], p.name
            if want[1] is not None:
                assert d["totals"]["goto_with_axis"] == want[1], p.name
        assert d["dialect"] == ("clsf" if p.parent.name == NX else "apt")


def test_project2_operations_units_and_axes(toolpaths):
    tp = toolpaths[f"{NX}/APT_Project2.txt"]
    d = describe_toolpath(tp)
    assert (d["dialect"], d["units"], len(d["operations"]), d["totals"]["arcs"]) == (
        "clsf", "inch", 15, 146)
    ops = {o["name"]: o for o in d["operations"]}
    assert ops["CAVITY_MILL"]["axis_class"] == "3-axis"
    assert ops["POCKETING_SLOT1"]["axis_class"] == "4-axis-Y"  # 3+2 axis (+-0.992, 0, 0.124)
    # distinct axes to 1e-3 as counted in SOURCES.txt
    assert ops["VARIABLE_AXIS_GUIDING_CURVES_1"]["distinct_axes"] == 1703
    assert ops["ROTARY_FLOOR"]["distinct_axes"] == 1520
    assert ops["ROTARY_FLOOR"]["axis_class"] == "multi-axis"
    first = tp.operations[0]
    assert first.tool_name == "MILL_0.120RAD"
    assert first.cutter.d == pytest.approx(0.75 * 25.4) and first.cutter.r == pytest.approx(
        0.12 * 25.4)
    m = tp.motion_arrays()
    np.testing.assert_allclose(m.tip[0], np.array([2.36, 2.2749, 3.53]) * 25.4)
    np.testing.assert_allclose(m.feed[~m.rapid & ~np.isnan(m.feed)][0], 10 * 25.4)
    assert tp.unknown == {}
    code = describe_toolpath(toolpaths[f"{NX}/APT_code.txt"])
    assert code["totals"]["distinct_axes"] == 290


def test_solidworks_csys_is_the_setup_frame_and_not_reapplied(toolpaths):
    """TRNTYP/WORLD: the GOTOs are already in the world frame; the CSYS z column is the setup's
    tool axis, which is exactly the axis the GOTOs carry."""
    tp = toolpaths[f"{SW}/Telemecanique-Tilt-Support1.apt"]
    assert tp.frames and not any(f.applied for f in tp.frames)
    m = tp.motion_arrays()
    np.testing.assert_allclose(m.axis, np.tile(tp.frames[0].matrix[:3, 2], (len(m), 1)),
                               atol=1e-6)
    np.testing.assert_allclose(m.tip[0], [-38.637201, -8.8, 247.043872])
    drill = toolpaths[f"{SW}/Sacrifice-Board.apt"].motion_arrays()
    assert sorted(set(drill.feed[drill.cycle])) == [364.49, 382.27]  # CYCLE/...,MMPM,f
    for tp in toolpaths.values():  # every cutting move has a feed
        m = tp.motion_arrays()
        assert not np.isnan(m.feed[~m.rapid]).any(), tp.path
    boss = describe_toolpath(toolpaths[f"{SW}/boss.apt"])
    assert boss["totals"]["axis_class"] == "4-axis-Y"  # horizontal spindle along x
    assert [o["axis_class"] for o in boss["operations"]] == ["3-axis"] * 4 + ["4-axis-Y"] * 4


def test_arcs_join_their_neighbours_tangentially(toolpaths):
    """Both dialects' CIRCLE direction conventions: where an arc meets a straight move, the
    sampled arc continues it (CAM lead-ins, corners) far more often than it reverses it."""
    for name, tp in toolpaths.items():
        if not tp.arcs:
            continue
        m = tp.motion_arrays()
        same = rev = 0
        for arc in tp.arcs:
            pts, k = arc.sample(0.001), arc.motion
            pairs = []
            if k >= 2 and m.arc[k - 1] == -1:
                pairs.append((pts[1] - pts[0], m.tip[k - 1] - m.tip[k - 2]))
            if k + 1 < len(m) and m.arc[k + 1] == -1:
                pairs.append((pts[-1] - pts[-2], m.tip[k + 1] - m.tip[k]))
            for t, s in pairs:
                n = np.linalg.norm(t) * np.linalg.norm(s)
                if n > 1e-12:
                    c = np.dot(t, s) / n
                    same += c > 0.99
                    rev += c < -0.99
        assert same > 10 * max(rev, 1) or (rev == 0 and same > 0), (name, same, rev)


def test_round_trip_every_file(toolpaths, tmp_path):
    for name, tp in toolpaths.items():
        out = tmp_path / (Path(name).name + ".apt")
        write_apt(tp, out)
        back = read_cl(out)
        assert len(back.records) == len(tp.records), name
        bad = [(a.line, b.line) for a, b in zip(tp.records, back.records, strict=True)
               if not a.same_as(b, rel=1e-9)]
        assert not bad, (name, bad[:3])
        m, mb = tp.motion_arrays(), back.motion_arrays()
        np.testing.assert_allclose(mb.tip, m.tip, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(mb.axis, m.axis, rtol=1e-9, atol=1e-12)
        assert (back.dialect, back.units, len(back.arcs)) == (tp.dialect, tp.units, len(tp.arcs))
        assert [o.name for o in back.operations] == [o.name for o in tp.operations]
