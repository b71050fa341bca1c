"""`pathcheck JOB --stock ... --fixture ...` as a real process on the mould sample (ball D10,
3-axis) in a vise (`tests/vise.py`): the summary's stock line against an independent height-field
simulation (`tests/stock_oracle.py`), the moved jaw's crashes against the geometry, the stock
written by `--stock-out` read back by trimesh, the stock the CL file states offered, a check
without a part, and every kind of bad input as one line, exit 2, nothing written."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hostile import assert_sane, run_pathcheck
from requires import require_extra
from stock_oracle import HeightField, Profile, simulate
from vise import MOULD, RADIUS, gotos, inner_face, into_jaw, vise

APT = MOULD / "mould.apt"
RESOLUTION = "0.2"
TOLERANCE = 0.02      # the job's tolerance (no INTOL/OUTTOL: the config's)
STOCK = ((-82.0, -57.0, -24.9981), (82.0, 57.0, 2.0))  # box:+2 about the part
FEED_DOWN = (20.0199, 250.0)  # the plunge from Z 25 to Z 4.9801 at FEDRAT/250: above the stock
_LINE = re.compile(r"^stock box from .* at 0\.2 mm; fixtures (\S+): crash (\d+)  holder (\d+); "
                   r"removed (\d+) of (\d+) mm\^3; air cuts (\d+) \((\d+) s\)(?:; as cut: .*)?$",
                   re.M)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    here = tmp_path_factory.mktemp("stock-cli")
    vise(here / "vise.stl")
    vise(here / "vise_in.stl", moved=True)
    return here


@pytest.fixture(scope="module")
def clean(folder):
    run = run_pathcheck([str(APT), "--no-store", "--stock", "box:+2", "--stock-resolution",
                         RESOLUTION, "--fixture", "vise.stl", "--json", "clean.json"],
                        cwd=folder)
    assert_sane(run, "")
    return run, json.loads((folder / "clean.json").read_text())


@pytest.fixture(scope="module")
def moved(folder):
    run = run_pathcheck([str(APT), "--no-store", "--stock", "box:+2", "--stock-resolution",
                         RESOLUTION, "--fixture", "vise_in.stl", "--json", "moved.json"],
                        cwd=folder)
    assert_sane(run, "")
    return run, json.loads((folder / "moved.json").read_text())


@pytest.fixture(scope="module")
def oracle():
    """The brute-force height field of the box stock cut by the job's ball along every move
    (grid and pose spacing 0.25 mm): (the removed volume in mm^3, per GOTO the largest depth its
    move cut)."""
    h = 0.25
    _, tips = gotos(APT)
    field = HeightField.box(STOCK[0], STOCK[1], h)
    start = np.zeros(len(tips), bool)
    start[0] = True
    cut = simulate(field, Profile(RADIUS, RADIUS), tips, start, h)
    removed = float((STOCK[1][2] - field.z).sum()) * h * h
    return removed, cut


def test_clean_vise_exit_0_and_the_stock_line_agrees_with_the_oracle(clean, oracle):
    run, doc = clean
    assert run.code == 0, run.why()
    (found,) = _LINE.findall(run.stdout)
    fixture, crash, holder, removed, initial, air, air_s = found
    assert "crash 0  holder 0" in run.stdout
    assert (fixture, crash, holder) == ("vise.stl", "0", "0")
    volume = np.prod(np.subtract(STOCK[1], STOCK[0]))
    assert float(initial) == pytest.approx(volume, rel=2e-3)  # the dexels' ray cells
    want, cut = oracle
    assert float(removed) == pytest.approx(want, rel=1e-3)  # measured: 4 mm^3 of 99,615
    s = doc["stock"]
    assert s["volume_initial"] - s["volume_final"] == pytest.approx(float(removed), abs=0.5)
    # air cuts: the feed moves that cut nothing (the oracle's depth within the tolerance): the
    # plunge above the stock, at its programmed feed
    lines, _ = gotos(APT)
    feed = np.zeros(len(lines), bool)
    feed[1:-1] = True  # the first and the last GOTO follow RAPID
    assert int(air) == int((feed & (cut <= TOLERANCE)).sum()) == 1
    (op,) = s["operations"]
    assert op["air_length"] == pytest.approx(FEED_DOWN[0], abs=1e-6)
    assert op["air_time_s"] == pytest.approx(60.0 * FEED_DOWN[0] / FEED_DOWN[1], rel=1e-9)
    assert int(air_s) == round(60.0 * FEED_DOWN[0] / FEED_DOWN[1])
    assert s["fixtures"] == ["vise.stl"] and s["findings"] == []


def test_stock_out_writes_closed_stls_with_the_documents_volume(folder):
    trimesh = require_extra("trimesh", "test")
    run = run_pathcheck([str(APT), "--no-store", "--stock", "box:+2", "--stock-resolution",
                         "1", "--stock-out", "stock", "--json", "out.json"], cwd=folder)
    assert run.code == 0, run.why()
    doc = json.loads((folder / "out.json").read_text())
    written = sorted(p.name for p in (folder / "stock").iterdir())
    assert written == ["stock_final.stl", "stock_op01.stl"]
    assert doc["stock"]["final_stl"] == "stock/stock_final.stl"
    assert doc["stock"]["operations"][0]["stl"] == "stock/stock_op01.stl"
    for name in written:
        m = trimesh.load(folder / "stock" / name)
        assert m.volume == pytest.approx(doc["stock"]["volume_final"], rel=1e-3)
        assert m.is_winding_consistent
        # closed: every edge is met by two faces, or by four where only diagonal neighbours
        # hold material (the union's own non-manifold edge: vertical, between ray columns)
        edges, count = np.unique(m.edges_sorted, axis=0, return_counts=True)
        assert set(count.tolist()) <= {2, 4}
        pinched = m.vertices[edges[count == 4]]
        assert np.abs(pinched[:, 0, :2] - pinched[:, 1, :2]).max(initial=0.0) < 1e-4
        assert m.is_watertight or (count == 4).sum() < 1e-4 * len(count)


def test_a_jaw_moved_into_the_path_is_a_crash_at_its_lines(moved):
    run, doc = moved
    assert run.code == 1, run.why()
    assert "FINDINGS" in run.stdout and "fixtures vise_in.stl: crash" in run.stdout
    lines, tips = gotos(APT)
    must, never = into_jaw(lines, tips, TOLERANCE)
    findings = doc["stock"]["findings"]
    assert findings and {f["verdict"] for f in findings} == {"crash"}
    assert {f["against"] for f in findings} == {"vise_in.stl"}
    reported = {f["line"] for f in findings}
    assert must <= reported and not reported & never
    # the deepest: the tool at the path's largest Y reaches INTO mm past the inner face
    deepest = max(findings, key=lambda f: f["depth"])
    assert deepest["depth"] == pytest.approx(3.0, abs=1e-6)
    assert deepest["point"][1] == pytest.approx(inner_face(), abs=1e-9)
    top = tips[:, 1].max()
    widest = set(lines[tips[:, 1] == top].tolist())
    assert deepest["line"] in widest
    # the worst-findings table names the fixture's crash and the line first
    table = run.stdout[run.stdout.index("worst findings"):]
    row = next(r for r in table.splitlines() if "fixture" in r)
    cells = [c.strip() for c in row.strip("│ ").split("│")]
    assert cells[1:4] == ["fixture", "crash", "3.0000"] and int(cells[0]) in widest
    assert doc["summary"]["status"] == "findings"
    assert doc["summary"]["counts"]["crash"] == len(findings)


def test_the_stock_the_cl_file_states_is_offered_and_checked_with_stock_cl(tmp_path):
    """SolidWorks CAM's `INSERT/Stock Size` added to a copy of the mould job: without --stock
    the stock line offers it, placed as `--stock cl` places it (centred on the part's X -80..80,
    Y -55..55, top at Z 0: the part's top), and `--stock cl` checks against that box."""
    shutil.copy(MOULD / "mould.json", tmp_path / "mould.json")
    text = APT.read_text().splitlines()
    assert text[2] == "CUTTER/10,5"
    (tmp_path / "mould.apt").write_text("\n".join([*text[:3], "INSERT/Stock Size X164. Y114. "
                                                   "Z27.", *text[3:]]) + "\n")
    run = run_pathcheck(["mould.apt", "--no-store"], cwd=tmp_path)
    assert run.code == 0, run.why()
    (said,) = [line for line in run.stdout.splitlines() if "stock" in line]
    assert said == ("stock: not checked (no --stock): rapids and holders were checked against "
                    "the part only; the CL file states a stock, --stock cl checks against it: "
                    "stated stock 164 x 114 x 27 mm (line 4), centred on the part in X and Y, "
                    "top at Z 0 (the CL frame's origin): X -82..82, Y -57..57, Z -27..0")
    run = run_pathcheck(["mould.apt", "--no-store", "--stock", "cl", "--stock-resolution", "0.5",
                         "--json", "cl.json"], cwd=tmp_path)
    assert run.code == 0, run.why()
    doc = json.loads((tmp_path / "cl.json").read_text())
    assert doc["job"]["stated_stock"] == said.rpartition("checks against it: ")[2]
    assert doc["stock"]["stock"] == doc["job"]["stated_stock"]
    assert doc["stock"]["volume_initial"] == pytest.approx(164 * 114 * 27, rel=5e-3)


@pytest.mark.parametrize("args, named", [
    (["--stock", "box:+x"], "--stock 'box:+x': expected box:+M"),
    (["--stock", "cylinder:q:+2"], "--stock 'cylinder:q:+2': expected cylinder:AXIS"),
    (["--stock", "missing.stl"], "--stock: the solid file 'missing.stl' does not exist"),
    (["--stock", "cl"], f"{APT}: --stock cl: the CL file states no stock"),
    (["--stock", "box:+2", "--fixture", "missing.stl"], "missing.stl: fixture file not found"),
    (["--stock", "box:+2", "--fixture", "vise.stl@1,2"], "--fixture 'vise.stl@1,2': expected"),
    (["--stock", "box:+2", "--stock-resolution", "0"], "--stock-resolution 0: expected"),
    (["--stock", "box:+2", "--stock-resolution", "0.00001"], "--stock-resolution 1e-05: expe"),
    (["--stock", "box:+2", "--stock-resolution", "0.001"],
     "--stock-resolution 0.001 mm: the stock (164 x 114 mm) would need"),
    (["--stock", "box:+2", "--stock-out", "a-file"], "Invalid value for '--stock-out'"),
    (["--fixture", "vise.stl", "--stock-out", "out"], "--stock-out writes the stock: expected"),
])
def test_bad_stock_input_is_one_line_exit_2_and_nothing_written(folder, tmp_path, args, named):
    shutil.copy(folder / "vise.stl", tmp_path / "vise.stl")
    (tmp_path / "a-file").write_text("kept\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    run = run_pathcheck([str(APT), "--no-store", "--json", "out.json", *args,
                         *([] if "--stock-out" in args else ["--stock-out", "out"])],
                        cwd=tmp_path)
    assert run.code == 2, run.why()
    assert_sane(run, named)
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "logs") == before
    assert (tmp_path / "a-file").read_text() == "kept\n"


def test_without_a_part_against_the_stock_and_the_vise_alone(folder, tmp_path):
    shutil.copy(APT, tmp_path / "mould.apt")
    for name in ("vise.stl", "vise_in.stl"):
        shutil.copy(folder / name, tmp_path / name)
    box = "box:-82,-57,-25,82,57,2"
    clean = run_pathcheck(["mould.apt", "--no-store", "--stock", box, "--stock-resolution",
                           "0.5", "--fixture", "vise.stl"], cwd=tmp_path)
    assert clean.code == 0, clean.why()
    assert "(no part: checked against the stock and the fixtures only)" in clean.stdout
    assert "fixtures vise.stl: crash 0  holder 0; removed" in clean.stdout
    hit = run_pathcheck(["mould.apt", "--no-store", "--stock", box, "--stock-resolution", "0.5",
                         "--fixture", "vise_in.stl", "--json", "alone.json"], cwd=tmp_path)
    assert hit.code == 1, hit.why()
    doc = json.loads((tmp_path / "alone.json").read_text())
    assert doc["job"]["part"] is None and doc["points"] == []
    lines, tips = gotos(APT)
    must, never = into_jaw(lines, tips, TOLERANCE)
    reported = {f["line"] for f in doc["stock"]["findings"]}
    assert must <= reported and not reported & never
    post = run_pathcheck(["mould.apt", "--no-store", "--stock", box, "--fixture", "vise.stl",
                          "-o", "out.nc"], cwd=tmp_path)
    assert_sane(post, "a check without a part does not post")
    assert post.code == 2 and not (tmp_path / "out.nc").exists()


def _gcode_positions(program: Path) -> tuple[np.ndarray, np.ndarray]:
    """(lines, tips (N, 3)) of the blocks of a G-code program that move X, Y or Z (modal
    words carried over; blocks before every axis is known left out)."""
    at = {"X": np.nan, "Y": np.nan, "Z": np.nan}
    lines, tips = [], []
    for number, text in enumerate(program.read_text().splitlines(), start=1):
        words = dict(re.findall(r"([XYZ])(-?[\d.]+)", text.split("(")[0]))
        if not words or "G28" in text:
            continue
        at.update({k: float(v) for k, v in words.items()})
        if not np.isnan(list(at.values())).any():
            lines.append(number)
            tips.append([at["X"], at["Y"], at["Z"]])
    return np.array(lines), np.array(tips)


def test_check_gcode_without_a_part_against_the_stock_and_the_vise(folder, tmp_path):
    """The mould job checked without a stock (the summary says so) and posted for a vertical
    machine, then read back by check-gcode with the cutter, a box stock and the vise and no
    part: clean in the vise, a crash at the blocks the geometry gives with the jaw moved into
    the path; a stock without the cutter refused."""
    for name in ("vise.stl", "vise_in.stl"):
        shutil.copy(folder / name, tmp_path / name)
    machine = ["--machine", "fanuc-vmc-a"]
    posted = run_pathcheck([str(APT), "--no-store", "-o", "prog.nc", *machine], cwd=tmp_path)
    assert posted.code == 0, posted.why()
    # without --stock the summary says in one line what was not checked
    said = [line for line in posted.stdout.splitlines() if "stock" in line]
    assert said == ["stock: not checked (no --stock): rapids and holders were checked against "
                    "the part only"]
    check = ["check-gcode", "prog.nc", *machine, "--cutter", "CUTTER/10,5", "--no-store",
             "--stock", "box:-82,-57,-25,82,57,2", "--stock-resolution", "0.5"]
    clean = run_pathcheck([*check, "--fixture", "vise.stl", "--json", "clean.json"],
                          cwd=tmp_path)
    assert clean.code == 0, clean.why()
    doc = json.loads((tmp_path / "clean.json").read_text())
    s = doc["stock"]
    assert s["fixtures"] == ["vise.stl"] and s["counts"]["crash"] == s["counts"]["holder"] == 0
    assert s["volume_final"] < s["volume_initial"] and doc["job"]["part"] is None
    assert sum(op["air_cuts"] for op in s["operations"]) == 1  # the plunge above the stock
    hit = run_pathcheck([*check, "--fixture", "vise_in.stl", "--json", "hit.json"],
                        cwd=tmp_path)
    assert hit.code == 1, hit.why()
    findings = json.loads((tmp_path / "hit.json").read_text())["stock"]["findings"]
    lines, tips = _gcode_positions(tmp_path / "prog.nc")
    must, never = into_jaw(lines, tips, TOLERANCE)
    reported = {f["line"] for f in findings}
    assert must and must <= reported and not reported & never
    assert {(f["verdict"], f["against"]) for f in findings} == {("crash", "vise_in.stl")}
    assert max(f["depth"] for f in findings) == pytest.approx(3.0, abs=1e-3)  # words in 0.001
    # a stock without the cutter cannot be checked: said, not skipped
    uncut = [c for c in check if c not in ("--cutter", "CUTTER/10,5")]
    refused = run_pathcheck([*uncut, "--fixture", "vise.stl", "--json", "no.json"],
                            cwd=tmp_path)
    assert_sane(refused, "--stock and --fixture check the program's tool")
    assert refused.code == 2 and not (tmp_path / "no.json").exists()


def test_the_stated_stock_of_a_real_solidworks_cam_job_is_offered(realdata, tmp_path):
    """Teste-Metrologia (amorim): `INSERT/Stock Size X85. Y38. Z48.` on line 9; its part (a
    float32 STL) spans X 0..85 and Y 0..38 to 4e-7 mm, so the stock centred on it in X and Y
    with its top at Z 0 is X 0..85, Y 0..38, Z -48..0, said to 0.1 um."""
    src = realdata / "amorim-solidworkscam-apt"
    apt, part = src / "Teste-Metrologia.apt", src / "Teste-Metrologia.STL"
    assert apt.read_text().splitlines()[8] == "INSERT/Stock Size X85. Y38. Z48."
    run = run_pathcheck([str(apt), "--part", str(part), "--no-store"], cwd=tmp_path)
    assert run.code in (0, 1), run.why()
    (said,) = [line for line in run.stdout.splitlines() if line.startswith("stock")]
    assert said.endswith("the CL file states a stock, --stock cl checks against it: stated "
                         "stock 85 x 38 x 48 mm (line 9), centred on the part in X and Y, top "
                         "at Z 0 (the CL frame's origin): X 0..85, Y 0..38, Z -48..0"), said
