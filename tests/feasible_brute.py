"""Test oracle: the refined boundary against a brute-force scan (docs/MATH.md §10.2), for any part
and CC points: along the grid line of every boundary edge, over the edge and one grid step beyond
each end, the orientations `step` apart are judged one by one (in one batch), and the brute-force
boundary is where neighbouring samples differ. A crossing is within the stated tolerance when it
lies within `tolerance` of a brute-force transition interval (the true boundary lies in that
interval; the crossing is on its feasible side). Radians."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from checker.five_axis.feasible import FeasibleRegion, Machine, feasible_at
from checker.five_axis.lead_tilt import local_frames


class BruteCheck(NamedTuple):
    """Per boundary edge (K,): `distance` (rad) from the refined crossing to the nearest
    brute-force transition interval on its line (0 inside one; inf when the scan found none),
    `transitions` the number of brute-force transitions on the edge itself (1 where the
    boundary crosses it once), and the scan's `step` (rad) and `poses` judged."""

    distance: np.ndarray
    transitions: np.ndarray
    step: float
    poses: int


def brute_force_check(region: FeasibleRegion, judge, cc: np.ndarray, normals: np.ndarray,
                      feeds: np.ndarray, *, step: float = math.radians(0.1),
                      machine: Machine | None = None) -> BruteCheck:
    """Scan every boundary edge of `region` (found with the same `judge`, CC points, normals,
    feeds and `machine`) at `step` (rad); see `BruteCheck`."""
    cc = np.asarray(cc, dtype=float).reshape(-1, 3)
    fr = local_frames(normals, feeds)
    k = len(region.edge_point)
    le, ti = region.leads, region.tilts
    # the line of each edge: along the lead (dim 0) or the tilt (dim 1), the other angle fixed
    dim = (region.edge_in[:, 0] == region.edge_out[:, 0]).astype(int)
    along = dim == 0
    fixed = np.where(along, ti[region.edge_in[:, 1]], le[region.edge_in[:, 0]])
    ends = np.column_stack([np.where(along, le[g[:, 0]], ti[g[:, 1]])
                            for g in (region.edge_in, region.edge_out)])
    lo_e, hi_e = ends.min(axis=1), ends.max(axis=1)
    start, stop = np.array([le[0], ti[0]]), np.array([le[-1], ti[-1]])
    pitch = (stop - start) / np.maximum(np.array([len(le), len(ti)]) - 1, 1)
    first = np.maximum(lo_e - pitch[dim], start[dim])
    last = np.minimum(hi_e + pitch[dim], stop[dim])
    count = np.ceil((last - first) / step - 1e-9).astype(int) + 1
    row = np.repeat(np.arange(k), count)
    pos = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    t = first[row] + (last - first)[row] * pos / np.maximum(count - 1, 1)[row]
    lead = np.where(along[row], t, fixed[row])
    tilt = np.where(along[row], fixed[row], t)
    ok = feasible_at(judge, cc, fr, region.edge_point[row], lead, tilt, machine)
    change = np.flatnonzero((row[1:] == row[:-1]) & (ok[1:] != ok[:-1]))
    a, b = t[change], t[change + 1]
    e = row[change]
    c = np.where(along, region.crossing[:, 0], region.crossing[:, 1])
    gap = np.maximum(np.maximum(a - c[e], c[e] - b), 0.0)
    distance = np.full(k, np.inf)
    np.minimum.at(distance, e, gap)
    on_edge = (a >= lo_e[e] - 1e-12) & (b <= hi_e[e] + 1e-12)
    transitions = np.bincount(e[on_edge], minlength=k)
    return BruteCheck(distance, transitions, float(step), int(len(t)))
