"""Best B in a passage (a hub and two blades around Y) against a brute-force scan of B in
0.05-degree steps with the same engine: b_best to 0.05 degrees and the allowable size there to
1e-3 mm."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from checker.config import default_config
from checker.cutter import parse_cutter
from checker.four_axis.best_b import best_b
from checker.four_axis.over_b import OverB, allowable_over_b
from checker.geometry import load_part
from checker.geometry.contact import cl_to_cc
from checker.geometry.sampling import sample_part
from checker.part import Part

B_RANGE = (-60.0, 60.0)
STEP = 0.05


@pytest.fixture(scope="module")
def passage(repo):
    """Hub + blade 0 + blade +1 of the compressor sample, and contact points of its small job
    on blade 0 (both sides), at mid span."""
    from checker.apt import read_cl

    full = load_part(repo / "samples/compressor/compressor_small.json")
    keep = [s for s in full.surfaces if s.name == "hub" or s.name.startswith(("blade+0",
                                                                             "blade+1"))]
    part = Part([dataclasses.replace(s, id=k) for k, s in enumerate(keep)])
    assert [s.name for s in part.surfaces] == ["hub", "blade+0_pressure", "blade+0_suction",
                                               "blade+1_pressure", "blade+1_suction"]
    tp = sample_part(part)
    job = read_cl(repo / "samples/compressor/compressor_small.apt")
    m = job.motion_arrays()
    cut = np.flatnonzero(~m.rapid)
    con = cl_to_cc(part, tp, job.operations[0].cutter, m.tip[cut], m.axis[cut])
    radius = np.hypot(con.cc[:, 0], con.cc[:, 2])
    on_blade = np.flatnonzero((radius > 84) & (radius < 110) & np.isin(con.surface, [1, 2]))
    rows = on_blade[:: max(1, len(on_blade) // 8)][:8]
    pick = dataclasses.replace(con, cc=con.cc[rows], normal=con.normal[rows],
                               surface=con.surface[rows], uv=con.uv[rows], gap=con.gap[rows])
    return part, tp, pick


def _dense_scan(fn, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The engine at every point and every B of the range in STEP degrees: (B (K,), (n, K))."""
    dense = np.arange(B_RANGE[0], B_RANGE[1] + 1e-9, STEP)
    rows = np.repeat(np.arange(n), dense.size)
    return dense, fn(rows, np.tile(dense, n)).reshape(n, dense.size)


def _assert_agrees_with_scan(best, dense: np.ndarray, scan: np.ndarray, cutter) -> None:
    """b_best and the size there against the dense scan (module docstring)."""
    top = scan.max(axis=1)
    strict_peaks = 0
    for i in range(len(scan)):
        if np.isinf(top[i]):  # unbounded at some B: best B is one of them
            assert np.isinf(best.allowable_at_best[i])
            inf_b = dense[np.isinf(scan[i])]
            assert inf_b.min() - STEP <= best.b_best[i] <= inf_b.max() + STEP
            continue
        # never below the scan's best, and above it by no more than the scan can miss between
        # its samples at a sharp maximum (half the change to the next sample) plus 1e-3 mm
        k = int(np.argmax(scan[i]))
        between = 0.5 * np.abs(np.diff(scan[i, max(k - 1, 0):k + 2])).max()
        assert top[i] - 1e-3 <= best.allowable_at_best[i] <= top[i] + between + 1e-3
        on_top = dense[scan[i] >= top[i] - 1e-4]  # the engine is exact to 1e-4 mm
        if on_top.max() - on_top.min() <= STEP:  # one maximum
            strict_peaks += 1
            assert best.b_best[i] == pytest.approx(dense[np.argmax(scan[i])], abs=STEP)
        else:  # a flat top (the curvature limit, the same at every B on it): b_best lies on it
            assert on_top.min() - STEP <= best.b_best[i] <= on_top.max() + STEP
    if cutter.kind == "bullnose":
        assert strict_peaks >= 4, "the passage should give the bull-nose clear best B values"


@pytest.mark.parametrize("cutter_text", ["CUTTER/12,2", "CUTTER/12,6"])
def test_best_b_agrees_with_a_brute_force_scan(passage, cutter_text):
    """A bull-nose's allowable size depends on B (clear maxima); a ball's is the curvature
    limit over a range of B (flat tops), where b_best must lie on the top."""
    part, tp, con = passage
    cutter = parse_cutter(cutter_text)
    fn = allowable_over_b(tp, part, cutter, con, default_config())
    n = len(con.cc)
    best = best_b(fn, n, b_min=B_RANGE[0], b_max=B_RANGE[1], coarse_step=4.0, tolerance=0.01,
                  required=cutter.size)
    _assert_agrees_with_scan(best, *_dense_scan(fn, n), cutter)


@pytest.mark.parametrize("cutter_text", ["CUTTER/12,2", "CUTTER/12,6"])
def test_tracked_refinement_agrees_with_a_brute_force_scan(passage, cutter_text):
    """The refinement on the sizes refined from the tracked limiting points (three engine
    evaluations per point instead of seventeen) meets the same brute-force scan."""
    part, tp, con = passage
    cutter = parse_cutter(cutter_text)
    over = OverB(tp, part, cutter, con, default_config())
    n = len(con.cc)
    best = best_b(over.sizes, n, b_min=B_RANGE[0], b_max=B_RANGE[1], coarse_step=4.0,
                  tolerance=0.01, required=cutter.size, tracked=over)
    _assert_agrees_with_scan(best, *_dense_scan(over.sizes, n), cutter)


@pytest.mark.parametrize("cutter_text", ["CUTTER/12,2", "CUTTER/12,6"])
def test_sizes_near_the_limiting_points_meet_the_engine(passage, cutter_text):
    """From the engine's own limiting points `sizes_near` finds the engine's size again (to
    1e-6 mm) or a smaller one (a size at a surface point, which the engine's minimum is at most
    in truth); 0 where the point faces away from the axis, as the engine."""
    part, tp, con = passage
    cutter = parse_cutter(cutter_text)
    over = OverB(tp, part, cutter, con, default_config())
    n = len(con.cc)
    b = np.arange(-30.0, 30.0 + 1e-9, 5.0)
    rows = np.repeat(np.arange(n), b.size)
    at = over.limited(rows, np.tile(b, n))
    near = over.near(rows, np.tile(b, n), at.surface[:, None], at.uv[:, None])
    assert ((near == 0.0) == (at.size == 0.0)).all() and (at.size == 0.0).any()
    bounded = np.isfinite(at.size) & (at.surface >= 0)
    assert bounded.sum() >= 20
    assert (near[bounded] <= at.size[bounded] + 1e-6).all()
    assert np.mean(np.abs(near[bounded] - at.size[bounded]) <= 1e-6) >= 0.95


@pytest.mark.parametrize("cutter_text", ["CUTTER/12,2", "CUTTER/12,6"])
def test_bounds_hold_and_skipping_changes_no_answer(passage, cutter_text):
    """`bound_over_b` never lies below the coarse engine's size (at every point and B of a
    2-degree scan), and the search that skips rows by it gives the same best B, size there and
    feasible intervals as the one that evaluates every row."""
    from checker.four_axis.over_b import bound_over_b, coarse_config

    part, tp, con = passage
    cfg = default_config()
    cutter = parse_cutter(cutter_text)
    fn = allowable_over_b(tp, part, cutter, con, cfg)
    coarse = allowable_over_b(tp, part, cutter, con, coarse_config(cfg))
    bound = bound_over_b(tp, part, cutter, con, coarse_config(cfg))
    n = len(con.cc)
    b = np.arange(B_RANGE[0], B_RANGE[1] + 1e-9, 2.0)
    rows = np.repeat(np.arange(n), b.size)
    assert (bound(rows, np.tile(b, n)) >= coarse(rows, np.tile(b, n))).all()
    required = cutter.size + cfg.check.tolerance
    args = dict(b_min=B_RANGE[0], b_max=B_RANGE[1], coarse_step=4.0, tolerance=0.01,
                required=required, coarse_fn=coarse)
    plain = best_b(fn, n, **args)
    skipped = best_b(fn, n, **args, bound_fn=bound)
    np.testing.assert_array_equal(skipped.b_best, plain.b_best)
    np.testing.assert_array_equal(skipped.allowable_at_best, plain.allowable_at_best)
    assert skipped.feasible == plain.feasible
