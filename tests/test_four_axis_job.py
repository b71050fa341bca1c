"""Issue 5 on real jobs: the compressor sample at its CAM orientation and re-oriented, the
orientation totals, intermediate poses between clean end points, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from geomdl import BSpline, exchange
from summary_text import summary_text

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.cli import cli
from checker.config import default_config

COMPRESSOR = "samples/compressor/compressor_small.apt"
COMPRESSOR_D12 = "samples/compressor/compressor_small_d12.apt"
FINDINGS = ("gouge", "interference", "holder", "crash")


def _greedy_asked():
    """The default config asking for the greedy smoothing beside the shortest path."""
    cfg = default_config()
    return cfg.model_copy(update={"four_axis": cfg.four_axis.model_copy(
        update={"greedy_baseline": True})})


@pytest.fixture(scope="module")
def small(repo):
    return check_job(repo / COMPRESSOR)


@pytest.fixture(scope="module")
def small_d12(repo):
    return check_job(repo / COMPRESSOR_D12)


def _cl(doc):
    """The cutting poses at CL records (the blade's 2 x 9 x 5 CC points)."""
    return [p for p in doc.points if p.kind == "cl" and p.cc is not None and not p.rapid]


def test_coarse_safe_path_touches_at_its_points_and_gouges_between_them(small):
    """The D6 touches the blade at every CL point at the CAM's B (within tolerance: the point
    lies on the triangles within their deviation); its straight moves between the 9 x 5 points
    cut into the curved blade (chord sag, up to 0.084 mm by the generator's own dense check),
    so the program has findings, and re-orientation cannot remove them: the CAM's angles are
    written."""
    assert small.job.axis_class == "4-axis-Y"
    cl = _cl(small)
    assert len(cl) == 2 * 9 * 5
    assert not [p for p in cl if p.verdict in FINDINGS]
    assert max(p.depth for p in cl) <= small.summary.tolerance
    moves = [p for p in small.points if p.kind == "move" and p.verdict in FINDINGS]
    assert moves and all(p.verdict == "gouge" for p in moves)
    assert 0.07 < max(p.depth for p in moves) < 0.09
    assert small.summary.status == "findings"
    (op,) = small.operations
    assert op.handling == "cam-kept" and op.counts_cam is None  # what is written is the CAM
    for p in cl:
        assert p.b_feasible, f"point {p.index} has no feasible B for the cutter it was made for"
        assert any(lo - 1e-6 <= p.b_original <= hi + 1e-6 for lo, hi in p.b_feasible)
        assert p.b == pytest.approx(p.b_original, abs=1e-9)


def test_larger_cutter_is_flagged_where_the_hub_or_the_next_blade_is_in_the_way(small_d12):
    """The D12 on the same CC points and axes: at the CAM's B the 18 points of the lowest rows
    dig into the hub (no B helps: no feasible B) and a few more hit the neighbouring blade with
    the flutes; the written program is re-oriented (fewer findings) and at its B only the hub
    points remain findings among the CL poses."""
    points = _cl(small_d12)
    radius = np.array([np.hypot(p.cc[0], p.cc[2]) for p in points])
    lowest = radius < 86.0  # the first span row, 4.8 mm above the hub (radius 80)
    at_cam = np.array([p.verdict_cam in FINDINGS for p in points])
    infeasible = np.array([not p.b_feasible for p in points])
    assert lowest.sum() == 18
    assert at_cam[lowest].all() and infeasible[lowest].all()
    others = np.flatnonzero(at_cam & ~lowest)
    assert 1 <= len(others) <= 6
    assert not infeasible[~lowest].any()
    (op,) = small_d12.operations
    assert op.handling == "re-oriented"
    written = np.array([p.verdict in FINDINGS for p in points])
    assert written[lowest].all() and not written[~lowest].any()
    assert small_d12.summary.status == "findings"
    c, cam = small_d12.summary.counts, small_d12.summary.counts_cam
    assert c.gouge + c.interference + c.holder < cam.gouge + cam.interference + cam.holder


def test_written_b_lies_in_the_feasible_intervals(small_d12):
    for p in _cl(small_d12):
        if p.b_feasible:
            assert any(lo - 1e-6 <= p.b <= hi + 1e-6 for lo, hi in p.b_feasible)
        assert p.allowable_at_best is None or p.allowable is None or \
            p.allowable_at_best >= p.allowable - 1e-6


def test_the_greedy_smoothing_is_planned_only_when_asked(small, small_d12):
    assert small.orientation.greedy_total_rotation is None
    assert small_d12.orientation.greedy_total_rotation is None
    assert "greedy" not in summary_text(small_d12)


def test_shortest_path_never_moves_more_than_the_greedy_smoothing(repo, small_d12):
    asked = check_job(repo / COMPRESSOR_D12, options=CheckOptions(config=_greedy_asked()))
    o = asked.orientation
    assert o.greedy_total_rotation is not None
    assert o.dp_total_rotation <= o.greedy_total_rotation
    assert o.dp_total_rotation == pytest.approx(small_d12.orientation.dp_total_rotation,
                                                abs=1e-9)  # asking changes nothing else
    assert asked.summary.counts == small_d12.summary.counts
    assert "greedy" in summary_text(asked)
    written = np.array([p.b for p in _cl(small_d12)])
    assert small_d12.orientation.dp_total_rotation == pytest.approx(
        np.abs(np.diff(written)).sum(), abs=1e-6)
    assert small_d12.orientation.infeasible_points == 18


def _bump_job(tmp_path):
    """A floor 30 x 10 mm with a smooth ridge 0.533 mm high across x = 15, and a ball D6 moving
    on the floor from x = 5 to x = 25: both ends clean, the middle of the move gouges."""
    surf = BSpline.Surface()
    surf.degree_u, surf.degree_v = 3, 1
    xs = [0, 5, 10, 13, 15, 17, 20, 25, 30]
    zs = [0, 0, 0, 0, 0.8, 0, 0, 0, 0]
    surf.ctrlpts_size_u, surf.ctrlpts_size_v = len(xs), 2
    surf.ctrlpts = [[x, y, z] for x, z in zip(xs, zs, strict=True) for y in (-5.0, 5.0)]
    surf.knotvector_u = [0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 6, 6, 6]
    surf.knotvector_v = [0, 0, 1, 1]
    exchange.export_json(surf, str(tmp_path / "bump.json"))
    (tmp_path / "bump.apt").write_text(
        "PARTNO/BUMP\nUNITS/MM\nCUTTER/6,3\nLOADTL/1\nFEDRAT/500,MMPM\n"
        "GOTO/5,0,0\nGOTO/25,0,0\nEND\nFINI\n")
    return tmp_path / "bump.apt"


def test_gouge_between_two_clean_end_points_is_caught(tmp_path):
    """Both CL poses are clean; the move between them crosses the ridge, whose top is the
    cubic B-spline's peak: 2/3 of its middle pole's height, 0.5333 mm. The move's deepest pose
    is found to within a tenth of its depth, and its depth is exact there."""
    doc = check_job(_bump_job(tmp_path))
    cl = [p for p in doc.points if p.kind == "cl"]
    assert [p.verdict for p in cl] == ["ok", "ok"]
    (move,) = [p for p in doc.points if p.kind == "move"]
    assert move.verdict == "gouge" and move.line == cl[1].line
    ridge = 0.8 * 2.0 / 3.0
    assert ridge * 0.9 - 1e-6 <= move.depth <= ridge + 1e-6
    assert move.tip[0] == pytest.approx(15.0, abs=0.5)
    assert doc.summary.counts.gouge == 1 and doc.summary.status == "findings"


def test_bad_four_axis_input_is_one_line_and_exit_2(tmp_path, repo):
    runner = CliRunner()
    job = tmp_path / "tilted.apt"
    job.write_text("PARTNO/T\nUNITS/MM\nMULTAX\nCUTTER/6,3\nLOADTL/1\nFEDRAT/500,MMPM\n"
                   "GOTO/5,0,3,0,0,1\nGOTO/6,0,3,0,0.2,0.98\nEND\nFINI\n")
    (tmp_path / "tilted.json").write_text((repo / "samples/mould/mould.json").read_text())
    from checker.cli import main

    def run(args):
        with pytest.raises(SystemExit) as ex:
            main(args)
        return ex.value.code

    assert run([str(job), "--b-range", "-30:30", "--no-store"]) == 2
    result = runner.invoke(cli, [str(job), "--b-range", "-30:30", "--no-store"],
                           standalone_mode=False)
    assert "tilted.apt:8:" in str(result.exception) and "not a 4-axis path" in str(result.exception)
    assert run([str(repo / COMPRESSOR), "--b-range", "-400:30", "--no-store"]) == 2
    assert run([str(repo / COMPRESSOR), "--b-range", "30:-30", "--no-store"]) == 2
    assert run([str(repo / COMPRESSOR), "--part", str(tmp_path / "nope.json"), "--no-store"]) == 2
    empty = tmp_path / "empty.apt"
    empty.write_text("PARTNO/E\nUNITS/MM\nCUTTER/6,3\nEND\nFINI\n")
    assert run([str(empty), "--no-store"]) == 2


def _wall_job(tmp_path):
    """A floor and a 40 mm wall 15 mm beside a ball D6's path along the floor."""
    from geomdl import multi

    def bilinear(corners):
        s = BSpline.Surface()
        s.degree_u = s.degree_v = 1
        s.ctrlpts_size_u = s.ctrlpts_size_v = 2
        s.ctrlpts = corners
        s.knotvector_u = s.knotvector_v = [0, 0, 1, 1]
        return s

    floor = bilinear([[0, -10, 0], [0, 30, 0], [40, -10, 0], [40, 30, 0]])  # du x dv = +z
    wall = bilinear([[0, 15, 0], [40, 15, 0], [0, 15, 40], [40, 15, 40]])  # faces -y
    exchange.export_json(multi.SurfaceContainer([floor, wall]), str(tmp_path / "wall.json"))
    (tmp_path / "wall.apt").write_text(
        "PARTNO/WALL\nUNITS/MM\nCUTTER/6,3\nLOADTL/1\nFEDRAT/500,MMPM\n"
        "GOTO/10,0,0\nGOTO/30,0,0\nEND\nFINI\n")
    return tmp_path / "wall.apt"


def test_holder_hit_reports_the_stickout_that_clears_it(tmp_path):
    from checker.tool_library import load_tool_library

    tool = load_tool_library()["BALL-D6"]  # holder D42 from 28 mm above the tip
    assert tool.holder_diameter / 2 > 15.0 and tool.stickout < 40.0
    doc = check_job(_wall_job(tmp_path), options=CheckOptions(cutter=tool))
    cl = [p for p in doc.points if p.kind == "cl"]
    assert [p.verdict for p in cl] == ["holder", "holder"]
    for p in cl:
        assert p.piece == "holder"
        assert p.holder_clearance == pytest.approx(40.0, abs=0.5)  # the wall's top
    # the bare cutter (no holder data) is clean there
    assert check_job(tmp_path / "wall.apt").summary.status == "ok"


@pytest.mark.slow
def test_full_compressor_path_is_clean_and_the_shortest_path_moves_less(repo):
    """The 2 x 41 x 41 sample job as in thesis chapter 5: clean at every pose and along every
    move at the CAM's B; the shortest path through the feasible B moves less than the CAM."""
    doc = check_job(repo / "samples/compressor/compressor.apt",
                    options=CheckOptions(config=_greedy_asked()))
    assert len(_cl(doc)) == 2 * 41 * 41  # the approach plunges do not touch: no contact
    assert doc.summary.status == "ok"
    o = doc.orientation
    assert o.infeasible_points == 0
    assert o.dp_total_rotation < o.original_total_rotation < o.greedy_total_rotation
