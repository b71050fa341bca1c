"""The stock and the fixtures on a real job: SolidWorks CAM's Teste-Metrologia (amorim, a 14 mm
flat end mill roughing around its part, then along its sides with the tool axis along +X; the
stock it states: 85 x 38 x 48 mm, top at Z 0) on its STL. Made from the real program and kept as
tests: a rapid lowered into the stock, a holder that reaches the stock beside the deep passes, a
table (fixture) raised into the path; each is reported with its line, verdict and depth, and the
same program without the change is clean against the stock and the fixtures."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from stl import mesh as stl_mesh

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.cutter import parse_cutter
from checker.stock.request import StockRequest

JOB = "Teste-Metrologia"
TOP = 0.0              # the stated stock's top (placed with its top at Z 0)
DEEPEST = -51.4375     # the program's lowest tip
HOLDER_R = 20.0        # the holder's radius
RAPID_LINE = 35        # `GOTO/-3.655561,-17.5,-7.5` after RAPID/: moved into the stock
RESOLUTION = 0.25      # mm: ray spacing of these tests


def _cutter(stickout: float, flutes: float = 32.0):
    """The job's CUTTER/14,0,7,...,84 with its flute length (CSI_SET_FLUTE_LENGTH/32.), a 14 mm
    shank and an ER32-like holder 40 mm wide and 50 mm long at `stickout` mm."""
    c = parse_cutter("CUTTER/14,0,7,0,0,0,84")
    return dataclasses.replace(c, flute_length=flutes, shank_diameter=14.0, stickout=stickout,
                               holder_diameter=40.0, holder_length=50.0)


def _table(path: Path, top: float) -> Path:
    """A table under the stock: the box [-300, 400] x [-300, 300] x [top - 100, top] as STL
    (wide and thick: a piece of the tool in it is deepest below its top)."""
    lo, hi = np.array([-300.0, -300.0, top - 100.0]), np.array([400.0, 300.0, top])
    corners = np.array([[hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1],
                         hi[2] if i & 4 else lo[2]] for i in range(8)])
    faces = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
             (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
    m = stl_mesh.Mesh(np.zeros(len(faces), dtype=stl_mesh.Mesh.dtype))
    m.vectors[:] = corners[np.array(faces)]
    m.save(str(path))
    return path


@pytest.fixture(scope="module")
def job(realdata, tmp_path_factory) -> dict:
    folder = tmp_path_factory.mktemp("metrologia")
    src = realdata / "amorim-solidworkscam-apt"
    apt = folder / f"{JOB}.apt"
    apt.write_text((src / f"{JOB}.apt").read_text())
    part = src / f"{JOB}.STL"
    return {"apt": apt, "part": part, "folder": folder,
            "table": _table(folder / "table.stl", -80.0)}


def _check(apt: Path, part: Path, stickout: float, fixtures=(), stock="cl", flutes=32.0):
    return check_job(apt, part, CheckOptions(
        cutter=_cutter(stickout, flutes), on_findings="comment",
        stock=StockRequest(stock, tuple(str(f) for f in fixtures), RESOLUTION)))


@pytest.fixture(scope="module")
def clean(job):
    return _check(job["apt"], job["part"], 60.0, [job["table"]])


def test_the_real_program_is_clean_against_its_stock_and_the_table(clean):
    s = clean.stock
    assert s.counts.crash == 0 and s.counts.holder == 0, s.findings[:3]
    assert s.volume_initial == pytest.approx(85 * 38 * 48, rel=0.01)
    assert 0.0 < s.volume_final < s.volume_initial
    assert s.fixtures == ["table.stl"]
    assert "stated stock 85 x 38 x 48 mm (line 9)" in s.stock
    # roughing around the part: material is removed and some feed moves cut nothing
    assert sum(op.removed for op in s.operations) == pytest.approx(
        s.volume_initial - s.volume_final, rel=1e-3)
    assert sum(op.air_cuts for op in s.operations) > 0
    assert len(s.engagement.move) == sum(op.feed_moves for op in s.operations)


def test_a_rapid_lowered_into_the_stock_is_a_crash_at_its_line(job, tmp_path):
    lines = job["apt"].read_text().splitlines()
    assert lines[RAPID_LINE - 1] == "GOTO/-3.655561,-17.5,-7.5"
    assert lines[RAPID_LINE - 2] == "RAPID/"
    lines[RAPID_LINE - 1] = "GOTO/20.,10.,-7.5"  # into material no move has removed yet
    apt = tmp_path / f"{JOB}.apt"
    apt.write_text("\n".join(lines) + "\n")
    doc = _check(apt, job["part"], 60.0, [job["table"]])
    crashes = [f for f in doc.stock.findings if f.verdict == "crash" and f.against == "stock"]
    assert [f.line for f in crashes] == [RAPID_LINE]
    f = crashes[0]
    assert f.rapid and f.piece == "body"
    bound = doc.stock.error_bound + 1e-3
    assert f.depth == pytest.approx(TOP - (-7.5), abs=bound)
    assert doc.summary.status == "findings"
    assert any(w.kind == "stock" and w.line == RAPID_LINE for w in doc.summary.worst)


def test_a_short_stickout_puts_the_holder_into_the_stock(job):
    """Flutes 20 mm long held at 20 mm: the first passes step down by 5.875 mm from Z -17, so
    at Z -22.875 the holder (40 mm wide) goes 2.875 mm into the stock beside the cut."""
    doc = _check(job["apt"], job["part"], 20.0, [job["table"]], flutes=20.0)
    hits = [f for f in doc.stock.findings if f.verdict == "holder"]
    assert hits and all(f.against == "stock" and f.line is not None for f in hits)
    first = min(hits, key=lambda f: f.line)
    assert first.piece == "holder"
    assert first.tip[2] == pytest.approx(-22.875)
    assert first.depth == pytest.approx(TOP - (-22.875 + 20.0), abs=1e-3)
    clean = _check(job["apt"], job["part"], 60.0, [job["table"]], flutes=20.0)
    assert clean.stock.counts.holder == 0


def test_a_table_raised_into_the_path_is_a_crash_naming_it(job, tmp_path):
    table = _table(tmp_path / "table.stl", -50.0)
    doc = _check(job["apt"], job["part"], 60.0, [table])
    into = [f for f in doc.stock.findings if f.against == "table.stl"]
    assert into and all(f.verdict == "crash" for f in into)
    # the deepest: the side passes (axis along +X) at the lowest tip, 1.4375 mm below the
    # table's top; a fixture's depth is that of its deepest point inside the tool (as for the
    # part): the top face on the axis's level, its distance to the tool's surface
    below = -50.0 - DEEPEST
    deepest = max(into, key=lambda f: f.depth)
    assert deepest.piece == "holder" and deepest.tip[2] == pytest.approx(DEEPEST, abs=1e-6)
    assert deepest.depth == pytest.approx(HOLDER_R - below, abs=0.02)
