"""A minimum hidden between the samples of a flat valley that falls towards a surface edge.

On the compressor job at B = 5.08 degrees (a CC point on blade 0's suction side, the ball D6),
the size on the next blade has a valley whose samples fall gently (0.001 mm per 1.4 mm spacing)
towards the surface edge v = 1, where the lowest sample lies; 3 mm inside, between the samples,
lies a minimum 0.003 mm lower, and no sample near it is a local minimum of the sample graph.
Before the near-minimal samples became refinement seeds (engine/scan/basins.py) the engine
stopped at the edge, 0.003 mm above the true minimum. Checked against the independent brute
force (tests/engine_oracle.py: bisection on "is the point inside the cutter") on a dense (u, v)
grid of the valley, in the tool frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from engine_oracle import _row_min

from checker.b_axis import axis_for_b
from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.engine.grid.frames import tool_rotations
from checker.geometry import load_part
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import sample_part

PART = Path(__file__).resolve().parents[1] / "samples" / "compressor" / "compressor.json"
CC = np.array([-0.5586038977809685, -1.3880989747894152, 112.51447558284549])
NORMAL = np.array([-0.6466755931732704, 0.7626614830217314, -0.0125753532392517])
CC_SURFACE, CC_UV = 3, np.array([0.5250005658301492, 0.9180012416637623])
B = 5.083592135001261  # degrees
VALLEY = 2  # the surface that holds the valley, its window in (u, v):
WINDOW = ((0.80, 0.95), (0.85, 1.0))
GRID = 601


@pytest.fixture(scope="module")
def case():
    part = load_part(PART)
    return part, sample_part(part), parse_cutter("CUTTER/6,3"), axis_for_b(np.array([B]))


def _brute(part, axis: np.ndarray) -> tuple[float, float]:
    """(the smallest size over the valley's grid, the smallest over the engine's own test
    points of that surface), mm, by the oracle in the tool frame."""
    Q = tool_rotations(axis)[0]
    cc, n = (Q @ CC)[None], (Q @ NORMAL)[None]
    (u0, u1), (v0, v1) = WINDOW
    U, V = np.meshgrid(np.linspace(u0, u1, GRID), np.linspace(v0, v1, GRID), indexing="ij")
    s = part.surfaces[VALLEY]
    out = []
    for pts in (evaluate(s, U.ravel(), V.ravel()).points, None):
        if pts is None:
            tp = sample_part(part)
            pts = tp.points[tp.surface == VALLEY]
        best, arg = np.empty(1), np.empty(1, dtype=np.int64)
        _row_min(True, 0.0, 0.0, cc, n, np.ascontiguousarray(pts @ Q.T), 1000.0, best, arg)
        out.append(float(best[0]))
    return out[0], out[1]


def test_the_minimum_between_the_samples_is_found(case):
    part, samples, cutter, axis = case
    brute, sampled = _brute(part, axis)
    assert sampled - brute >= 0.002, "the samples should miss the valley's minimum"
    got = allowable(samples, part, cutter, CC[None], NORMAL[None], axis,
                    cc_surface=np.array([CC_SURFACE]), cc_uv=CC_UV[None]).size[0]
    # never above the brute force by more than its grid can miss (~1e-5 mm here); a size at a
    # surface point, so never below the true minimum, which the grid approaches from above
    assert brute - 1e-4 <= got <= brute + 1e-4, (got, brute, sampled)
