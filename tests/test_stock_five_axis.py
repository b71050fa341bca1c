"""The stock model on the 5-axis impeller sample (samples/impeller/passage.apt: a ball D6 along the
hub with its axis turning by 466 degrees in all) against an oracle that samples each ray along
z: at the same poses (the CL motion, tip straight and axis turning linearly between the records,
poses no farther apart than STEP for any point of the tool), a point of the ray is removed when
it lies inside the tool (ball end and flutes, written here from the cutter's numbers, with the
check's rounded cap) at some pose. Points RES apart along every ray of the model: the removed
length per ray agrees with the model's (exact per pose) to the points' spacing per end of a
removed stretch; the removed volume to a fraction of a percent. Through the check: a box stock
around the part, removed volume within the bound of the same (the machine's joints linear
between the records, not the CL's straight tip)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from checker.apt import read_cl
from checker.check import check_job
from checker.check.options import CheckOptions
from checker.cutter import parse_cutter
from checker.mesh.tool import tool_pieces
from checker.stock.dexels import Dexels
from checker.stock.removal import remove
from checker.stock.request import StockRequest

RES = 0.5           # mm between rays and between the oracle's points along them
STEP = 0.5          # mm any point of the tool travels between poses at most
FLUTES = 25.0       # mm: the body's length (no shank, no holder given)
R = 3.0             # the ball's radius


@pytest.fixture(scope="module")
def poses(repo):
    tp = read_cl(repo / "samples" / "impeller" / "passage.apt")
    m = tp.motion_arrays()
    a, e = m.tip[:-1], m.tip[1:]
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", m.axis[:-1], m.axis[1:]), -1.0, 1.0))
    travel = np.linalg.norm(e - a, axis=1) + turn * FLUTES
    n = np.maximum(np.ceil(travel / STEP).astype(int), 1)
    k = np.repeat(np.arange(len(n)), n)
    t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + 1) / np.repeat(n, n)
    tips = np.vstack([m.tip[:1], a[k] + t[:, None] * (e[k] - a[k])])
    axes = np.vstack([m.axis[:1], m.axis[:-1][k] + t[:, None] * (m.axis[1:][k] - m.axis[:-1][k])])
    return tips, axes / np.linalg.norm(axes, axis=1, keepdims=True)


def _box(tips):
    return tips.min(axis=0) - 4.0, tips.max(axis=0) + 4.0


def _oracle_removed(stock: Dexels, tips: np.ndarray, axes: np.ndarray, lo, hi) -> np.ndarray:
    """(ny, nx) mm removed along each ray: points RES apart from lo z to hi z, each removed
    when within R of the axis segment from R to FLUTES above the tip (the ball end, the flutes
    and, as the check's solid has it (checker/mesh/tool.py), a rounded cap on them)."""
    xs, ys = stock.xs(), stock.ys()
    zs = lo[2] + (np.arange(int(round((hi[2] - lo[2]) / RES))) + 0.5) * RES
    gone = np.zeros((len(ys), len(xs), len(zs)), bool)
    for tip, ax in zip(tips, axes, strict=True):
        end = tip + (FLUTES + R) * ax
        blo = np.minimum(tip, end) - R
        bhi = np.maximum(tip, end) + R
        i = slice(*np.searchsorted(xs, [blo[0], bhi[0]]))
        j = slice(*np.searchsorted(ys, [blo[1], bhi[1]]))
        k = slice(*np.searchsorted(zs, [blo[2], bhi[2]]))
        X, Y, Z = np.meshgrid(xs[i], ys[j], zs[k], indexing="xy")
        p = np.stack([X - tip[0], Y - tip[1], Z - tip[2]], axis=-1)
        h = np.clip(p @ ax, R, FLUTES)
        off = p - h[..., None] * ax
        inside = np.einsum("...i,...i->...", off, off) <= R * R
        gone[j, i, k] |= inside
    return gone.sum(axis=2) * RES


def test_removed_length_per_ray_agrees_with_the_oracle(poses):
    tips, axes = poses
    lo, hi = _box(tips)
    stock = Dexels.box(lo, hi, RES)
    inside = stock.count > 0  # the rays whose centre is in the box (the last column may not)
    before = np.where(inside, stock.hi[:, :, 0] - stock.lo[:, :, 0], 0.0)
    cutter = dataclasses.replace(parse_cutter("CUTTER/6,3"), flute_length=FLUTES)
    n = len(tips)
    got = remove(stock, tool_pieces(cutter, with_holder=True), tips, tips, axes,
                 np.arange(n), n, step=STEP)
    slot = np.arange(stock.capacity)[None, None, :] < stock.count[:, :, None]
    after = np.where(slot, stock.hi.astype(float) - stock.lo, 0.0).sum(axis=2)
    model = before - after
    oracle = np.where(inside, _oracle_removed(stock, tips, axes, lo, hi), 0.0)
    assert oracle.sum() > 1000 * RES ** 2  # it cut
    diff = np.abs(model - oracle)
    assert (diff <= 2 * RES + 1e-3).mean() > 0.999, np.quantile(diff, [0.99, 1.0])
    assert (diff <= 4 * RES + 1e-3).all()
    assert got.volume[:, 0].sum() == pytest.approx(model.sum() * RES ** 2, rel=1e-6)
    assert model.sum() == pytest.approx(oracle.sum(), rel=0.01)


def test_the_check_simulates_the_impeller_on_a_box_stock(repo):
    doc = check_job(repo / "samples" / "impeller" / "passage.apt",
                    options=CheckOptions(stock=StockRequest("box:+2", (), 0.5)))
    s = doc.stock
    assert s.volume_initial > s.volume_final > 0.0
    assert s.operations[0].removed == pytest.approx(s.volume_initial - s.volume_final, rel=1e-3)
    assert s.error_bound <= 0.25 + 1e-9  # step = h: poses of the turning moves h apart
    assert s.overflow == 0
