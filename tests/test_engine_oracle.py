"""The engine against an independent brute-force oracle (tests/engine_oracle.py: dense sampling
plus bisection on a point-inside-cutter test) on the mould sample: 130 CC points for each of a
ball, a bull-nose, a flat and a tapered ball cutter (520 in all) agree to 1e-3 mm."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from engine_oracle import oracle_sizes

from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.geometry import load_part
from checker.geometry.sampling import sample_part

MOULD = Path(__file__).resolve().parents[1] / "samples" / "mould" / "mould.json"
CUTTERS = ["CUTTER/10,5", "CUTTER/10,2", "CUTTER/10", "CUTTER/9.1633,5,0,5,0,5,0"]


@pytest.fixture(scope="module")
def mould():
    if not MOULD.is_file():
        pytest.skip("samples/mould/mould.json not built (samples/make_samples.py)")
    part = load_part(MOULD)
    return part, sample_part(part)


@pytest.mark.parametrize("cut", CUTTERS)
def test_engine_matches_brute_force_oracle(mould, cut):
    part, tp = mould
    rng = np.random.default_rng(CUTTERS.index(cut))
    cand = np.flatnonzero(tp.normals[:, 2] > 0.2)
    pick = rng.choice(cand, 130, replace=False)
    cc, n = tp.points[pick], tp.normals[pick]
    c = parse_cutter(cut)
    res = allowable(tp, part, c, cc, n, cc_surface=tp.surface[pick], cc_uv=tp.uv[pick])
    ref = oracle_sizes(part, c, cc, n, dense=120)
    both = np.isfinite(ref) & np.isfinite(res.size)
    assert (np.isfinite(ref) == np.isfinite(res.size)).all()
    err = np.abs(res.size[both] - ref[both])
    assert err.max() < 1e-3, f"{cut}: max |engine - oracle| = {err.max():.2e} mm"
