"""The engine against an independent brute-force oracle (tests/engine_oracle.py: dense sampling
plus bisection on a point-inside-cutter test) on the mould sample: 130 CC points for each of a
ball, a bull-nose, a flat and a tapered ball cutter, 520 in all.

Both only ever report sizes of real surface points (or, for the flat end-mill, the closed-form
limit at the CC point), so each is an upper bound of the true minimum: the engine must never be
above the oracle by more than 1e-3 mm (it would call a cutter safe that is not), and the two must
agree to 1e-3 mm on at least AGREE_MIN of the 520 points (where they differ, the engine is the
lower, i.e. the oracle's grids missed the minimum)."""

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
PER_CUTTER = 130
AGREE_MIN = 500


@pytest.fixture(scope="module")
def comparison():
    part = load_part(MOULD)
    tp = sample_part(part)
    out = []
    for k, cut in enumerate(CUTTERS):
        rng = np.random.default_rng(k)
        cand = np.flatnonzero(tp.normals[:, 2] > 0.2)
        pick = rng.choice(cand, PER_CUTTER, replace=False)
        cc, n = tp.points[pick], tp.normals[pick]
        c = parse_cutter(cut)
        res = allowable(tp, part, c, cc, n, cc_surface=tp.surface[pick], cc_uv=tp.uv[pick])
        ref = oracle_sizes(part, c, cc, n, dense=100, cc_surface=tp.surface[pick],
                           cc_uv=tp.uv[pick])
        out.append((cut, res.size, ref))
    return out


def test_unbounded_points_agree(comparison):
    for cut, eng, ref in comparison:
        assert (np.isfinite(eng) == np.isfinite(ref)).all(), cut


def test_engine_matches_brute_force_oracle(comparison, capsys):
    agree, misses, lines = 0, 0, []
    for cut, eng, ref in comparison:
        both = np.isfinite(eng) & np.isfinite(ref)
        d = np.where(both, eng - np.where(both, ref, 0.0), 0.0)
        ok = np.abs(d) <= 1e-3
        agree += int(ok.sum())
        misses += int((d > 1e-3).sum())
        lines.append(f"{cut:28} agree {ok.sum():3d}/{len(d)}  engine above oracle by > 1e-3: "
                     f"{(d > 1e-3).sum():2d} (max {d.max():.2e})  below: {(d < -1e-3).sum():2d} "
                     f"(min {d.min():.2e})")
    with capsys.disabled():
        print("\n" + "\n".join(lines))
    assert agree >= AGREE_MIN
    assert misses == 0
