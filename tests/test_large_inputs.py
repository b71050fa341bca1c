"""Large inputs: the CL reader keeps arrays, not an object per GOTO (memory a move measured by
tracemalloc), `info` counts from them, and what cannot be streamed is refused beyond a bound in
one line naming the file and the bound (docs/formats.md, "Job sizes and memory")."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from checker import input_limits
from checker.apt import read_cl, read_cl_text
from checker.apt.read import BLOCK_BYTES
from checker.apt.toolpath_info import describe_toolpath
from checker.cc_csv import read_cc_csv
from checker.cli import main
from checker.errors import PathcheckError

REPO = Path(__file__).resolve().parents[1]
MOVES = 50_000
# bytes a move while reading and describing: 10 M moves within 2 GB (an object per GOTO, as
# the reader kept before, costs 400 B kept and 660 B at the peak)
BYTES_PER_MOVE = 200
BLOCKS = 4 * BLOCK_BYTES  # the first pass reads the file in blocks


def _program(path: Path, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A program of n GOTOs (every seventh with a tilted axis, kept by the 3-value ones after
    it) between a header and an operation change; (tips, axes) as the reader must give them."""
    k = np.arange(n)
    tip = np.column_stack([k * 0.01, np.sin(k * 1e-3), 5.0 + (k % 13) * 0.001])
    axis = np.tile([0.0, 0.0, 1.0], (n, 1))
    with_axis = k % 7 == 3
    for j in np.flatnonzero(with_axis):
        axis[j:] = [0.6, 0.0, 0.8] if j % 2 else [0.0, 0.0, 1.0]
    lines = ["PARTNO/LARGE", "UNITS/MM", "CUTTER/10,5", "FEDRAT/500,MMPM"]
    for j in range(n):
        s = f"GOTO/{tip[j, 0]:.4f},{tip[j, 1]:.6f},{tip[j, 2]:.3f}"
        lines.append(s + (f",{axis[j, 0]:.1f},{axis[j, 1]:.1f},{axis[j, 2]:.1f}"
                          if with_axis[j] else ""))
        if j == n // 2:
            lines += ["LOADTL/2", "CUTTER/6,3"]
    path.write_text("\n".join(lines + ["FINI"]) + "\n")
    for c, decimals in enumerate((4, 6, 3)):
        tip[:, c] = np.round(tip[:, c], decimals)
    return tip, axis


def test_reading_and_describing_keeps_arrays_not_objects(tmp_path):
    path = tmp_path / "large.apt"
    tip, axis = _program(path, MOVES)
    describe_toolpath(read_cl_text("CUTTER/6\nGOTO/1,2,3\n"), axis_tol=1e-3)  # lazy imports
    tracemalloc.start()
    try:
        tp = read_cl(path)
        _, read_peak = tracemalloc.get_traced_memory()
        doc = describe_toolpath(tp, axis_tol=1e-3)
        kept, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert read_peak < BLOCKS + BYTES_PER_MOVE * MOVES, read_peak / MOVES
    assert peak < BLOCKS + BYTES_PER_MOVE * MOVES, peak / MOVES
    assert kept < BYTES_PER_MOVE * MOVES
    np.testing.assert_allclose(tp.motions.tip, tip, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tp.motions.axis, axis, rtol=0, atol=1e-12)
    # the counts, from the arrays, against the program as written
    t = doc["totals"]
    assert (t["goto"], t["motions"], t["records"]) == (MOVES, MOVES, MOVES + 7)
    assert t["goto_with_axis"] == int(np.sum(np.arange(MOVES) % 7 == 3))
    assert t["distinct_axes"] == 2 and t["axis_class"] == "4-axis-Y"
    half = MOVES // 2 + 1
    assert [op["goto"] for op in doc["operations"]] == [half, MOVES - half]
    assert [op["first_line"] for op in doc["operations"]] == [1, half + 5]


def test_records_made_on_demand_are_the_records_of_the_text():
    text = ("PARTNO/MIX\nCUTTER/6\nGOTO/1,2,3\nGOTO/4,5,6,0,0,1\nFEDRAT/100\n"
            "GOTO/7,8,9 $$ 1,2,3\nGOTO/1,1,1\nFINI\n")
    recs = read_cl_text(text).records
    want = [("PARTNO", ()), ("CUTTER", (6.0,)), ("GOTO", (1.0, 2.0, 3.0)),
            ("GOTO", (4.0, 5.0, 6.0, 0.0, 0.0, 1.0)), ("FEDRAT", (100.0,)),
            ("GOTO", (7.0, 8.0, 9.0)), ("GOTO", (1.0, 1.0, 1.0)), ("FINI", ())]
    assert [(r.word, r.args) for r in recs] == want
    assert [(recs[i].word, recs[i].args, recs[i].line) for i in range(len(recs))] == \
        [(w, a, n) for n, (w, a) in enumerate(want, start=1)]
    assert recs[-2].args == (1.0, 1.0, 1.0) and recs[5].comment == " 1,2,3"
    assert [r.line for r in recs[2:4]] == [3, 4]


def test_statements_beyond_the_bound_are_refused_plain_gotos_are_not(monkeypatch):
    monkeypatch.setattr("checker.apt.lexer.MAX_CL_STATEMENTS", 5)
    gotos = "".join(f"GOTO/{k},0,0\n" for k in range(100))
    assert len(read_cl_text(f"CUTTER/6\nFEDRAT/100\n{gotos}FINI\n").motions) == 100
    text = "CUTTER/6\n" + "FEDRAT/100\nGOTO/1,2,3\n" * 5  # the 6th statement on line 10
    with pytest.raises(PathcheckError, match=r"^<string>:10: 6 or more statements other than "
                       r"plain GOTOs: expected at most 5 \(checker\.input_limits\."
                       r"MAX_CL_STATEMENTS\); split the job$"):
        read_cl_text(text)


def test_a_check_beyond_the_pose_bound_is_refused_before_it_starts(monkeypatch, tmp_path,
                                                                  capsys):
    monkeypatch.setattr(input_limits, "MAX_CHECK_POSES", 10)
    job = REPO / "samples" / "mould" / "mould.apt"
    n = len(read_cl(job).motions)
    with pytest.raises(SystemExit) as exc:
        main([str(job), "--no-store", "--json", str(tmp_path / "out.json")])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and not (tmp_path / "out.json").exists()
    assert err.splitlines() == [f"pathcheck: {job}: {n:,} poses to check: expected at most 10 "
                                "(checker.input_limits.MAX_CHECK_POSES); split the job"]


def test_cc_points_beyond_the_bound_are_refused_naming_the_row(monkeypatch, tmp_path):
    monkeypatch.setattr(input_limits, "MAX_CC_POINTS", 3)
    cc = tmp_path / "cc.csv"
    rows = ["x,y,z,nx,ny,nz"] + [f"{k},0,0,0,0,1" for k in range(3)]
    cc.write_text("\n".join(rows) + "\n")
    points, normals = read_cc_csv(cc)
    assert points[:, 0].tolist() == [0.0, 1.0, 2.0]
    cc.write_text("\n".join([*rows, "", "3,0,0,0,0,1"]) + "\n")
    with pytest.raises(PathcheckError, match=r"cc\.csv:6: 4 CC points: expected at most 3 "
                       r"\(checker\.input_limits\.MAX_CC_POINTS\)"):
        read_cc_csv(cc)


def test_an_allowable_search_in_chunks_is_the_search_whole(monkeypatch):
    from checker.config import load_config
    from checker.cutter import cutter_from_apt
    from checker.geometry import load_part
    from checker.operations import allowable as op

    mould = REPO / "samples" / "mould"
    config = load_config(None)
    cc, normals = read_cc_csv(mould / "cc.csv")
    part = op.sampled_part(lambda: load_part(mould / "mould.json", geometry=config.geometry),
                           config)
    cutter = cutter_from_apt([10.0, 2.0])
    axis = np.array([0.0, 0.0, 1.0])
    monkeypatch.setattr(op, "CHUNK_ROWS", len(cc) + 1)
    whole = op.allowable_at_points(part, cutter, cc, normals, axis, config)
    monkeypatch.setattr(op, "CHUNK_ROWS", 7)
    chunked = op.allowable_at_points(part, cutter, cc, normals, axis, config)
    assert len(chunked["points"]) == len(cc) > 7
    for a, b in zip(whole["points"], chunked["points"], strict=True):
        assert (a["advice"], a["limiting_surface"]) == (b["advice"], b["limiting_surface"])
        assert (a["allowable"] is None) == (b["allowable"] is None)
        if a["allowable"] is not None:
            assert abs(a["allowable"] - b["allowable"]) <= 1e-9 * max(1.0, a["allowable"])
    assert sum(p["allowable"] is not None for p in whole["points"]) > 7  # sizes compared
