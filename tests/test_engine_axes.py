"""Rows with their own tool axes (engine bins, checker/engine/grid/bins.py): allowable sizes of many
distinct axes at once (candidates found through a grid built for a nearby axis) equal those of one
axis at a time (a grid for each row's own axis), also for 4-axis rows close in B that fall into
different bins."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from checker.b_axis import axis_for_b
from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.engine.grid.bins import _BIN_DEG, _OWN_GRID_ROWS, axis_bins, part_tops
from checker.engine.grid.rotations import tool_rotation, tool_rotations
from checker.geometry.sampling import TestPoints

SAMPLE = "samples/compressor/compressor"
SAME = 1e-9  # mm
# mm: along a valley floor flat to SAME the limiting point itself is only fixed to microns
SAME_POINT = 1e-5


def _tilted(rng, axis, n, max_deg):
    """n unit axes within max_deg degrees of `axis`."""
    a = axis + np.tan(np.radians(max_deg)) * rng.uniform(-0.7, 0.7, (n, 3))
    return a / np.linalg.norm(a, axis=1)[:, None]


def test_tool_rotations_are_the_rows_of_tool_rotation():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(40, 3))
    a[:3] = [[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0]]
    a /= np.linalg.norm(a, axis=1)[:, None]
    Q = tool_rotations(a)
    single = np.array([tool_rotation(x) for x in a])
    assert np.abs(Q - single).max() < 1e-15
    assert np.abs(np.einsum("nij,nj->ni", Q, a) - [0, 0, 1.0]).max() < 1e-14
    assert np.abs(Q @ Q.transpose(0, 2, 1) - np.eye(3)).max() < 1e-14


def test_axis_bins_cover_rows_within_the_lattice_step():
    rng = np.random.default_rng(3)
    b = rng.uniform(-40, 40, 500)
    shared = np.full(_OWN_GRID_ROWS, 12.5)
    axes = axis_for_b(np.concatenate([b, shared, [7.0, 7.0]]))
    Q = tool_rotations(axes)
    seen = np.zeros(len(axes), dtype=int)
    for rows, axis, Qb, D in axis_bins(axes, Q):
        seen[rows] += 1
        assert np.degrees(np.arccos(np.clip(axes[rows] @ axis, -1, 1))).max() <= _BIN_DEG
        assert np.abs(Qb @ axis - [0, 0, 1.0]).max() < 1e-14
        if D is None:
            assert np.abs(Q[rows] - Qb).max() == 0.0  # rows of the grid's own frame
        else:
            assert np.abs(D - Q[rows] @ Qb.T).max() == 0.0
    assert (seen == 1).all()
    own = [rows for rows, _, _, D in axis_bins(axes, Q) if D is None and rows.size > 2]
    assert any(set(r) == set(range(500, 500 + _OWN_GRID_ROWS)) for r in own)


@pytest.fixture(scope="module")
def compressor():
    from checker.apt import read_cl
    from checker.geometry import load_part
    from checker.geometry.contact import cl_to_cc
    from checker.geometry.sampling import sample_part

    part = load_part(f"{SAMPLE}.json")
    tp = sample_part(part)
    m = read_cl(f"{SAMPLE}.apt").motion_arrays()
    cut = np.flatnonzero(~m.rapid)[::40][:48]
    con = cl_to_cc(part, tp, parse_cutter("CUTTER/6,3"), m.tip[cut], m.axis[cut])
    return part, tp, con, m.axis[cut]


def _one_at_a_time(part, tp, cutter, con, axes, rows):
    return [allowable(tp, part, cutter, con.cc[[i]], con.normal[[i]], axes[[i]],
                      cc_surface=con.surface[[i]], cc_uv=con.uv[[i]]) for i in rows]


def _assert_same(res, singles, rows):
    size = np.array([r.size[0] for r in singles])
    np.testing.assert_allclose(res.size[rows], size, atol=SAME, rtol=0)
    point = np.array([r.limiting_point[0] for r in singles])
    np.testing.assert_allclose(res.limiting_point[rows], point, atol=SAME_POINT, rtol=0)
    assert list(res.advice[rows]) == [r.advice[0] for r in singles]


def test_part_tops_equal_the_highest_point(compressor):
    _, tp, _, axes = compressor
    Q = tool_rotations(axes)
    np.testing.assert_allclose(part_tops(tp, Q), (tp.points @ Q[:, 2].T).max(axis=0), atol=1e-9)


def test_part_tops_of_a_flat_point_set():
    """Coplanar test points have no 3-D hull: every point counts."""
    rng = np.random.default_rng(2)
    pts = np.column_stack([rng.uniform(-5, 5, (300, 2)), np.full(300, 1.5)])
    Q = tool_rotations(_tilted(rng, np.array([0, 0, 1.0]), 20, 30.0))
    up = np.tile([0.0, 0.0, 1.0], (300, 1))
    tp = TestPoints(pts, up, np.zeros(300, np.int32), np.zeros((300, 2)), np.ones(300),
                    cKDTree(pts))
    tops = part_tops(tp, Q)
    np.testing.assert_allclose(tops, (pts @ Q[:, 2].T).max(axis=0), atol=1e-12)


@pytest.mark.parametrize("cut", ["CUTTER/6,3", "CUTTER/6,1", "CUTTER/6,0"])
def test_distinct_axes_at_once_equal_one_axis_at_a_time(compressor, cut):
    """The CAM's own 4-axis axes (all different): sizes, limiting points and advice of one
    call with every axis equal those of a call per row (a grid built for that row's axis)."""
    part, tp, con, axes = compressor
    cutter = parse_cutter(cut)
    assert len(np.unique(np.round(axes, 12), axis=0)) == len(axes)
    res = allowable(tp, part, cutter, con.cc, con.normal, axes, cc_surface=con.surface,
                    cc_uv=con.uv)
    bins = axis_bins(axes, tool_rotations(axes))
    assert len(bins) < len(axes) // 3 and sum(D is not None for *_, D in bins) >= 2
    rows = np.arange(0, len(axes), 3)
    _assert_same(res, _one_at_a_time(part, tp, cutter, con, axes, rows), rows)
    assert np.isfinite(res.size).sum() > len(axes) // 2


def test_four_axis_rows_close_in_b_across_bins_agree_with_direct(compressor):
    """Each CC point at B just below and just above a lattice boundary (odd degrees), in one
    call with many other B values, against the direct evaluation of each (row, B)."""
    part, tp, con, _ = compressor
    cutter = parse_cutter("CUTTER/6,3")
    n = len(con.cc)
    edge = _BIN_DEG * (np.arange(n) % 9 - 4) + 0.5 * _BIN_DEG
    b = np.concatenate([edge - 1e-3, edge + 1e-3, np.linspace(-20, 20, n)])
    idx = np.tile(np.arange(n), 3)
    axes = axis_for_b(b)
    res = allowable(tp, part, cutter, con.cc[idx], con.normal[idx], axes,
                    cc_surface=con.surface[idx], cc_uv=con.uv[idx])
    Q = tool_rotations(axes)
    bin_of = np.empty(len(b), dtype=int)
    for k, (rows, *_) in enumerate(axis_bins(axes, Q)):
        bin_of[rows] = k
    assert (bin_of[:n] != bin_of[n:2 * n]).all()  # the two sides of each pair: different bins
    rows = np.concatenate([np.arange(0, n, 4), n + np.arange(0, n, 4)])
    singles = [allowable(tp, part, cutter, con.cc[[idx[i]]], con.normal[[idx[i]]], axes[[i]],
                         cc_surface=con.surface[[idx[i]]], cc_uv=con.uv[[idx[i]]])
               for i in rows]
    _assert_same(res, singles, rows)
    # 0.002 degrees apart: the allowable size barely moves across the boundary
    both = np.isfinite(res.size[:n]) & np.isfinite(res.size[n:2 * n])
    assert both.sum() > n // 2
    assert np.abs(res.size[:n] - res.size[n:2 * n])[both].max() < 0.05


def test_small_first_trial_gives_the_same_answer_from_fewer_candidates(compressor, monkeypatch):
    """(CC point, B) rows far from the CAM's B: the scan's small first trial (scan.search.scan
    `first`) finds the same seeds (refinement starts) and bit-identical sizes, limiting points
    and advice as a start at the nearest points' upper bound, with fewer kernel evaluations."""
    import checker.engine.api as api

    part, tp, con, _ = compressor
    cutter = parse_cutter("CUTTER/6,3")
    idx = np.tile(np.arange(len(con.cc)), 2)
    axes = axis_for_b(np.linspace(-60, 60, idx.size))
    kw = dict(cc_surface=con.surface[idx], cc_uv=con.uv[idx])
    starts = []  # the refinement starts (from the scan's seeds) of each call

    def spy(part, cutter, frame, Q, rows, sid, uv, *rest):
        starts.append((rows.copy(), sid.copy(), uv.copy()))
        return refine(part, cutter, frame, Q, rows, sid, uv, *rest)

    refine = api.refine
    monkeypatch.setattr(api, "refine", spy)
    res = allowable(tp, part, cutter, con.cc[idx], con.normal[idx], axes, **kw)
    monkeypatch.setattr(api, "_FIRST_TRIAL", np.inf)  # first trial = the upper bound
    ref = allowable(tp, part, cutter, con.cc[idx], con.normal[idx], axes, **kw)
    for a, b in zip(*starts, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(res.size, ref.size)
    np.testing.assert_array_equal(res.limiting_point, ref.limiting_point)
    np.testing.assert_array_equal(res.advice, ref.advice)
    assert np.isfinite(res.size).sum() > len(idx) // 2
    assert res.evaluations.sum() < 0.8 * ref.evaluations.sum()
