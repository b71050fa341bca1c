"""The bundled sample jobs: they are what samples/make_samples.py builds (numerically, see
`_same_numbers`), the
parts have the required surfaces, degrees, poles, joins and normals, the jobs read as 4-axis
(compressor) and 3-axis (mould) paths, their CL points sit on the part (CL -> CC gap ~ 0 at
every feed move), and a larger cutter on the same compressor path gouges."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

from checker.apt import read_cl
from checker.cutter import cutter_from_apt
from checker.geometry import find_part_beside, load_part
from checker.geometry.contact import cl_to_cc
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import sample_part

_SCRIPT = Path(__file__).resolve().parents[1] / "samples" / "make_samples.py"
_spec = importlib.util.spec_from_file_location("make_samples", _SCRIPT)
make_samples = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_samples)
ROUNDING = 2e-4  # mm: the APT files carry 4 decimals


@pytest.fixture(scope="module")
def rebuilt(tmp_path_factory):
    """Every sample built afresh into a temporary folder."""
    out = tmp_path_factory.mktemp("samples")
    make_samples.build_compressor(out / "compressor")
    make_samples.build_mould(out / "mould")
    make_samples.build_impeller(out / "impeller")
    make_samples.build_flank(out / "flank")
    return out


_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
REL = 1e-9  # relative agreement of numbers written in full (JSON floats)


def _same_numbers(committed: str, rebuilt: str, fixed_decimals: bool) -> None:
    """The two texts agree where it matters on any CPU: the same words and punctuation, and
    numbers equal to within one unit in their last written decimal where the file rounds to a
    fixed number of decimals (APT: 4 for positions, 7 for axes; a value on a rounding edge may
    flip its last digit), else to within REL relative (JSON floats written in full: their last
    bits differ between CPUs' vector units)."""
    words_a, words_b = _NUMBER.split(committed), _NUMBER.split(rebuilt)
    assert words_a == words_b, "the texts differ in more than their numbers"
    nums_a, nums_b = _NUMBER.findall(committed), _NUMBER.findall(rebuilt)
    a, b = np.array(nums_a, dtype=float), np.array(nums_b, dtype=float)
    if fixed_decimals:
        places = [len(t.partition(".")[2].lower().partition("e")[0]) for t in nums_a]
        allowed = 10.0 ** -np.array(places, dtype=float)
    else:
        allowed = REL * np.maximum(np.abs(a), 1.0)
    bad = np.flatnonzero(np.abs(a - b) > allowed * (1 + 1e-9))
    assert bad.size == 0, f"{bad.size} numbers differ, first: {nums_a[bad[0]]} vs {nums_b[bad[0]]}"


def test_numbers_compare_within_their_written_precision():
    _same_numbers("GOTO/1.2345,7", "GOTO/1.2346,7", True)
    _same_numbers('{"x": -3.4357988758362947}', '{"x": -3.4357988758362943}', False)
    for committed, rebuilt, fixed in (("GOTO/1.2345,7", "GOTO/1.2347,7", True),
                                      ('{"x": 1.0}', '{"x": 1.00001}', False),
                                      ("GOTO/1.2345", "GOTO/1.2345,7", True),
                                      ("GOTO/1,2", "GOTA/1,2", True)):
        with pytest.raises(AssertionError):
            _same_numbers(committed, rebuilt, fixed)


@pytest.mark.parametrize("name", ["compressor/compressor.json", "compressor/compressor.apt",
                                  "compressor/compressor_small.json",
                                  "compressor/compressor_small.apt",
                                  "compressor/compressor_small_d12.json",
                                  "compressor/compressor_small_d12.apt", "compressor/cc.csv",
                                  "mould/mould.json", "mould/mould.apt", "mould/cc.csv",
                                  "impeller/passage.json", "impeller/passage.apt",
                                  "impeller/cc.csv", "flank/hypar.json", "flank/hypar.apt"])
def test_committed_files_are_what_the_script_builds(repo, rebuilt, name):
    _same_numbers((repo / "samples" / name).read_text(), (rebuilt / name).read_text(),
                  fixed_decimals=name.endswith((".apt", ".csv")))


def test_compressor_part(repo):
    part = load_part(repo / "samples/compressor/compressor.json")
    names = [s.name for s in part.surfaces]
    assert names == ["hub"] + [f"blade{k:+d}_{side}" for k in (-1, 0, 1)
                               for side in ("pressure", "suction")]
    hub = part.surfaces[0]
    assert hub.rational and (hub.degree_u, hub.degree_v) == (2, 1)
    u = np.linspace(0, 1, 50)
    ev = evaluate(hub, u, np.full(50, 0.3))
    radial = ev.points * [1, 0, 1]
    np.testing.assert_allclose(np.linalg.norm(radial, axis=1), make_samples.R_HUB, atol=1e-9)
    np.testing.assert_allclose(ev.normals, radial / make_samples.R_HUB, atol=1e-9)
    for s in part.surfaces[1:]:
        assert (s.degree_u, s.degree_v) == (5, 5) and s.ctrlpts.shape == (6, 6, 3)
        assert not s.rational
    # normals leave the blade: the suction side faces +phi, the pressure side -phi
    for k, phi in enumerate(make_samples.BLADE_PHI):
        circ = np.array([np.cos(phi), 0.0, -np.sin(phi)])
        press, suct = part.surfaces[1 + 2 * k], part.surfaces[2 + 2 * k]
        assert evaluate(press, [0.5], [0.5]).normals[0] @ circ < -0.5
        assert evaluate(suct, [0.5], [0.5]).normals[0] @ circ > 0.5
        # sharp leading and trailing edges: both sides share their edge curves
        v = np.linspace(0, 1, 11)
        for up, us in ((0.0, 1.0), (1.0, 0.0)):
            a = evaluate(press, np.full(11, up), v).points
            b = evaluate(suct, np.full(11, us), v).points
            np.testing.assert_allclose(a, b, atol=1e-9)


def test_mould_part_joins(repo):
    part = load_part(repo / "samples/mould/mould.json")
    s = {x.name: x for x in part.surfaces}
    assert len(part.surfaces) == 8
    t = np.linspace(0, 1, 21)
    one, zero = np.ones(21), np.zeros(21)
    # C0 crease at x = 0: same points, different normals
    left, right = evaluate(s["cavity_LF"], one, t), evaluate(s["cavity_RF"], zero, t)
    np.testing.assert_allclose(left.points, right.points, atol=1e-9)
    angle = np.degrees(np.arccos(np.einsum("ij,ij->i", left.normals, right.normals)))
    assert angle[1:-1].min() > 1.0 and angle[10:].min() > 10.0  # the crease fades at the rim
    # C1 join at y = 0: same points and the same first derivative across it
    front, back = evaluate(s["cavity_LF"], t, one), evaluate(s["cavity_LB"], t, zero)
    np.testing.assert_allclose(front.points, back.points, atol=1e-9)
    np.testing.assert_allclose(front.dv, back.dv, atol=1e-9)
    assert np.abs(front.dv[:, 2]).max() > 1.0  # a real slope, not a flat join
    # the rim lies on the parting plane and meets the plates; the cavity is below it
    rim = evaluate(s["cavity_LF"], zero, t).points
    np.testing.assert_allclose(rim[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(rim[:, 0], -make_samples.CAV_X, atol=1e-12)
    inner = evaluate(s["cavity_RB"], np.full(21, 0.5), t)
    assert inner.points[1:-1, 2].max() < 0 and (inner.normals[:, 2] > 0).all()
    for x in part.surfaces:
        uv = np.linspace(0.05, 0.95, 9)
        assert (evaluate(x, uv, uv[::-1]).normals[:, 2] > 0).all(), x.name


def _feed_moves(path):
    tp = read_cl(path)
    ma = tp.motion_arrays()
    cut = ~ma.rapid & (ma.feed == 800.0)
    return tp, ma, cut


def test_compressor_job_is_four_axis_about_y(repo):
    job = repo / "samples/compressor/compressor.apt"
    assert "PPRINT/MACHINE fanuc-hmc" in job.read_text().splitlines()
    assert find_part_beside(job) == job.with_suffix(".json")
    tp, ma, cut = _feed_moves(job)
    c = tp.operations[0].cutter
    assert (c.kind, c.d, c.r) == ("ball", 6.0, 3.0)
    assert cut.sum() == 2 * 41 * 41
    assert (ma.axis[:, 1] == 0.0).all()
    # B = atan2(-i, k): the radial direction at the blade (+-15 deg) turned 20 deg towards
    # the pressure side (+B) or the suction side (-B)
    b = np.degrees(np.arctan2(-ma.axis[cut, 0], ma.axis[cut, 2]))
    pressure, suction = b[:41 * 41], b[41 * 41:]
    assert pressure.min() > 5 and pressure.max() < 35
    assert suction.min() > -35 and suction.max() < -5


def test_compressor_cl_points_sit_on_blade_zero(repo):
    job = repo / "samples/compressor/compressor.apt"
    part = load_part(job.with_suffix(".json"))
    tp, ma, cut = _feed_moves(job)
    got = cl_to_cc(part, sample_part(part), tp.operations[0].cutter, ma.tip[cut], ma.axis[cut])
    assert np.abs(got.gap).max() < ROUNDING
    # each contact is on the side it was planned on, also on the edges both sides share
    assert (got.surface[:41 * 41] == 3).all() and (got.surface[41 * 41:] == 4).all()
    assert (np.einsum("ij,ij->i", got.normal, ma.axis[cut]) > 0.1).all()  # facing the tool
    # the recovered CC points are the generator's 41 x 41 grids
    cutter = cutter_from_apt([6.0, 3.0])
    us, vs = np.linspace(0, 1, 41), np.linspace(make_samples.COMP_V0, 1, 41)
    want = np.concatenate([make_samples.grid_pass(part, sid, us, vs, cutter,
                                                  make_samples.compressor_axes).cc
                           for sid in (3, 4)])
    np.testing.assert_allclose(got.cc, want, atol=1e-3)


def test_mould_cl_points_sit_on_the_cavity(repo):
    job = repo / "samples/mould/mould.apt"
    part = load_part(job.with_suffix(".json"))
    tp, ma, cut = _feed_moves(job)
    assert (ma.axis == [0.0, 0.0, 1.0]).all()
    c = tp.operations[0].cutter
    assert (c.kind, c.d) == ("ball", 10.0)
    got = cl_to_cc(part, sample_part(part), c, ma.tip[cut], ma.axis[cut])
    assert np.abs(got.gap).max() < ROUNDING
    assert np.isin(got.surface, [0, 1, 2, 3, 6, 7]).all()   # cavity, or the rim edge


def test_small_jobs_d6_clean_d12_flagged_on_the_hub(repo):
    """The small jobs (2 x 9 x 5 CC points): the D6 touches everywhere; the D12 on the same CC
    points and axes has its centre 6 mm off the blade, so on the lowest row (4.8 mm above the
    hub) of each side it cuts into the hub, and touches elsewhere."""
    folder = repo / "samples" / "compressor"
    part = load_part(folder / "compressor_small.json")
    tp_points = sample_part(part)
    gaps = {}
    for stem in ("compressor_small", "compressor_small_d12"):
        tp, ma, cut = _feed_moves(folder / f"{stem}.apt")
        assert cut.sum() == 2 * 9 * 5 and find_part_beside(folder / f"{stem}.apt") is not None
        got = cl_to_cc(part, tp_points, tp.operations[0].cutter, ma.tip[cut], ma.axis[cut])
        gaps[stem] = got.gap.reshape(2, 5, 9), got.surface.reshape(2, 5, 9)
    assert np.abs(gaps["compressor_small"][0]).max() < ROUNDING
    gap, surface = gaps["compressor_small_d12"]
    # it touches the blade it was made for and digs into the hub: the gap is the hub's
    assert (gap[:, 0] < -0.5).all() and np.isin(surface[:, 0], [3, 4]).all()
    assert np.abs(gap[:, 1:]).max() < ROUNDING


def test_larger_ball_gouges_the_compressor_path(repo):
    """The small job's CC points and axes with larger balls (tips recomputed for each): the D6
    touches everywhere; a D12's centre lies 6 mm off the blade, so on the lowest row (4.8 mm
    above the hub) it cuts into the hub and nowhere else; a D16 also reaches the neighbouring
    blade across the passage."""
    part = load_part(repo / "samples/compressor/compressor_small.json")
    tp = sample_part(part)
    us, vs = np.linspace(0, 1, 9), np.linspace(make_samples.COMP_V0, 1, 5)
    res = {}
    for d in (6.0, 12.0, 16.0):
        cutter = cutter_from_apt([d, d / 2])
        ps = make_samples.grid_pass(part, 3, us, vs, cutter, make_samples.compressor_axes)
        got = cl_to_cc(part, tp, cutter, ps.tips, ps.axes)
        res[d] = got.gap.reshape(5, 9), got.surface.reshape(5, 9)
    assert np.abs(res[6.0][0]).max() < 1e-6
    gap, surface = res[12.0]
    assert (gap[0] < -0.5).all() and np.isin(surface[0], [3, 4]).all()
    assert np.abs(gap[1:]).max() < 1e-6 and np.isin(surface[1:], [3, 4]).all()
    gap, surface = res[16.0]
    assert (gap < -0.3).sum() >= 5
