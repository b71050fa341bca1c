"""Packed trims (`pack_trims` + `kept`, used by the compiled refinement) against the
vectorised `UVTrim.contains` and against the analytic region they approximate: the disc
|(u, v) - (0.5, 0.5)| < 0.4 with the square hole |u - 0.5|, |v - 0.5| < 0.1, as polylines."""

from __future__ import annotations

import numba as nb
import numpy as np

from checker.geometry.trims import UVTrim, kept, pack_trims

_DISC = 0.5 + 0.4 * np.column_stack([np.cos(t := np.linspace(0, 2 * np.pi, 400, endpoint=False)),
                                     np.sin(t)])
_HOLE = np.array([(0.4, 0.4), (0.6, 0.4), (0.6, 0.6), (0.4, 0.6)])


@nb.njit(cache=True)
def _kept_all(T, s, u, v):
    out = np.empty(u.shape[0], dtype=np.bool_)
    for i in range(u.shape[0]):
        out[i] = kept(T, s, u[i], v[i])
    return out


def test_packed_trims_agree_with_contains_and_the_region():
    trims = [None, UVTrim([_DISC], [_HOLE]), UVTrim([_DISC]), UVTrim([], [_HOLE])]
    T = pack_trims(trims)
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-0.1, 1.1, 20_000), rng.uniform(-0.1, 1.1, 20_000)
    r = np.hypot(u - 0.5, v - 0.5)
    in_disc, in_hole = r < 0.4, (np.abs(u - 0.5) < 0.1) & (np.abs(v - 0.5) < 0.1)
    truth = [np.ones(u.size, bool), in_disc & ~in_hole, in_disc, ~in_hole]
    clear = (np.abs(r - 0.4) > 1e-3) & (np.abs(np.maximum(np.abs(u - 0.5), np.abs(v - 0.5)) - 0.1)
                                        > 1e-9)
    for s, trim in enumerate(trims):
        got = _kept_all(T, s, u, v)
        if trim is not None:
            assert (got == trim.contains(u, v)).all(), s
        assert (got[clear] == truth[s][clear]).all(), s
    assert 0 < truth[1].sum() < u.size  # both kinds of points are drawn
