"""The stock model against an independent oracle on a real 3-axis job: the first operation
("Sides", a 3D contour in 11 levels) of the Fusion 360 program Spinner_Demo.nc (asmbl, a 2 mm
flat end mill, G0/G1 only) on a box stock around its STL.

The oracle (`stock_oracle`) reads the program with a regular expression of its own, drops the
flat end's exact profile on a grid at the model's own rays at poses `STEP` mm apart, and so
bounds the exact sweep from both sides: with the real radius R it can only leave more material
(its poses are a subset of the motion); with R + STEP / 2, lowered by STEP / 2, it can only
leave less (every pose of the motion is within STEP / 2 of a sampled one). Every ray of the
model must lie between the two: the model's removal is exact per ray for vertical moves
(docs/MATH.md §14). The air cuts are cross-checked the same way."""

from __future__ import annotations

import re

import numpy as np
import pytest
from stock_oracle import HeightField, Profile, simulate

from checker.cutter import parse_cutter
from checker.mesh.tool import tool_pieces
from checker.moves import FEED, machine_moves
from checker.stock.dexels import Dexels
from checker.stock.removal import remove
from checker.stock.removal_items import sweep_items
from checker.toolpath import MotionArrays

STEP = 0.02          # mm between the oracle's poses
H = 0.05             # mm between rays
MARGIN = 1.0         # mm of stock around the part's box
SIDES_END = 7291     # the last line of the first operation ("(TopSurfacing)" is line 7292)
TOL = 0.01           # mm: a feed move that removes no more is an air cut
_XYZ = re.compile(r"^(G[01])\s+X(-?[\d.]+)\s+Y(-?[\d.]+)\s+Z(-?[\d.]+)")


@pytest.fixture(scope="module")
def job(realdata):
    folder = realdata / "asmbl-fusion360-gcode"
    lines = (folder / "Spinner_Demo.nc").read_text().splitlines()[:SIDES_END]
    tips, rapid = [], []
    for text in lines:
        found = _XYZ.match(text)
        if found:
            tips.append([float(v) for v in found.groups()[1:]])
            rapid.append(found.group(1) == "G0")
    from stl import mesh

    part = mesh.Mesh.from_file(str(folder / "Spinner_Demo.stl"))
    lo = part.vectors.reshape(-1, 3).min(axis=0) - MARGIN
    hi = part.vectors.reshape(-1, 3).max(axis=0) + MARGIN
    return np.array(tips), np.array(rapid), lo, hi


@pytest.fixture(scope="module")
def model(job):
    """The stock model after the operation, and the air cuts it counts (per pose)."""
    tips, rapid, lo, hi = job
    n = len(tips)
    nan, zero = np.full(n, np.nan), np.zeros(n, np.int64)
    m = MotionArrays(tips, np.tile([0.0, 0.0, 1.0], (n, 1)), rapid, np.where(rapid, nan, 500.0),
                     nan, np.arange(n), zero, np.zeros(n, bool), zero - 1, zero - 1)
    moves = machine_moves(m)
    stock = Dexels.box(lo, hi, H)
    box = np.array([lo, hi])
    items = sweep_items(moves, np.arange(len(moves)), box, H)
    got = remove(stock, tool_pieces(parse_cutter("CUTTER/2"), with_holder=True), *items,
                 len(moves), step=H)
    air = (moves.kind == FEED) & (got.thickness.max(axis=1) <= TOL)
    return stock, got, air, moves


def _oracle(job, stock: Dexels, radius: float):
    tips, rapid, lo, hi = job
    field = HeightField(stock.x0 + 0.5 * H, stock.y0 + 0.5 * H, H,
                        np.full((stock.ny, stock.nx), float(hi[2])))
    start = np.zeros(len(tips), bool)
    start[0] = True
    cut = simulate(field, Profile(radius, 0.0), tips, start, STEP)
    return field, cut


@pytest.fixture(scope="module")
def oracles(job, model):
    stock = model[0]
    return _oracle(job, stock, 1.0), _oracle(job, stock, 1.0 + 0.5 * STEP)


def test_every_ray_lies_between_the_oracle_bounds(model, oracles):
    stock = model[0]
    (upper, _), (lower, _) = oracles
    top = stock.top()
    assert np.isfinite(top).all()
    assert (top <= upper.z + 1e-4).all(), float((top - upper.z).max())
    assert (top >= lower.z - 0.5 * STEP - 1e-4).all(), float((lower.z - 0.5 * STEP - top).max())
    # and the operation really cut: the 11 levels down to Z 0.4 around the part
    removed = upper.z < top.max() - 1.0
    assert removed.mean() > 0.1
    assert np.abs(top - upper.z)[removed].mean() < 0.01


def test_air_cuts_and_engaged_depths_agree_with_the_oracle(model, oracles):
    """Per feed move, the largest thickness the model removes on one ray against the oracle's
    largest drop at one grid point (the same rays): equal to the sampling's bound but on the
    few moves whose cut grazes a ray at the cutter's edge (a lateral sliver of the sampling's
    size); the air cuts (no more than TOL removed) the same moves."""
    _, got, air, moves = model
    (_, cut_r), _ = oracles
    feed = np.flatnonzero(moves.kind == FEED)
    row = moves.row[feed]  # poses are the program's G0/G1 rows here (no cycles)
    model_cut = got.thickness[feed].max(axis=1)
    oracle_air = cut_r[row] <= TOL
    assert 100 < oracle_air.sum() < len(feed) - 1000
    assert (air[feed] != oracle_air).sum() <= len(feed) // 1000
    close = np.abs(model_cut - cut_r[row]) <= 0.5 * STEP + 1e-4
    assert close.mean() > 0.995
