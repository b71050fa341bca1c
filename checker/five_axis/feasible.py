"""The feasible tool orientations per CC point (docs/MATH.md §10.2): a coarse (lead, tilt) grid
within the machine's limits, every pose judged by the check's verdict rule in one batched call,
then the boundary refined on every grid edge between a feasible and an infeasible node by
bisection, all edges of all points together (one batched call per halving), to a stated angle
tolerance. This is the C-space of Jun, Lee and Cha (2002) with its coarse grid and boundary search;
the boundary is found on the grid's lines (the crossings), not traced by turning left and right on a
fine grid. A feasible island or gap narrower than the grid step can be missed. Radians, part
frame."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from checker.five_axis.lead_tilt import Frames, axes_from_angles, local_frames

LIMIT = math.radians(60.0)     # default |lead|, |tilt| limit
STEP = math.radians(5.0)       # default coarse grid step
TOLERANCE = math.radians(0.01)  # default angle tolerance of the boundary

Machine = Callable[[np.ndarray], np.ndarray]  # unit axes (M, 3), part frame -> reachable (M,)


class FeasibleRegion(NamedTuple):
    """The feasible orientations of N CC points. `leads (L,)`, `tilts (T,)` the grid (rad);
    `mask (N, L, T)` whether each grid orientation is feasible; per boundary edge k (a grid edge
    with a feasible and an infeasible end): `edge_point (K,)` its CC row, `edge_in (K, 2)` and
    `edge_out (K, 2)` the (lead, tilt) grid indices of its feasible and infeasible end,
    `crossing (K, 2)` (lead, tilt) rad on the edge, feasible, with an infeasible orientation of
    the edge within `tolerance` rad of it (the boundary on the feasible side). Compact: the
    mask as bits (`packed`) and K crossings."""

    leads: np.ndarray
    tilts: np.ndarray
    mask: np.ndarray
    edge_point: np.ndarray
    edge_in: np.ndarray
    edge_out: np.ndarray
    crossing: np.ndarray
    tolerance: float

    def packed(self) -> np.ndarray:
        """(N, ceil(L T / 8)) uint8: each point's mask, lead-major, as bits
        (`np.unpackbits(..., count=L * T)` gives it back)."""
        return np.packbits(self.mask.reshape(len(self.mask), -1), axis=1)


def angle_grid(lo: float, hi: float, step: float) -> np.ndarray:
    """Evenly spaced angles from `lo` to `hi` (rad, both included) at most `step` apart."""
    if hi < lo or step <= 0.0:
        raise ValueError(f"bad angle range {lo}..{hi} or step {step}")
    return np.linspace(lo, hi, int(math.ceil((hi - lo) / step - 1e-9)) + 1)


def feasible_at(judge, cc: np.ndarray, frames: Frames, point: np.ndarray, lead: np.ndarray,
                tilt: np.ndarray, machine: Machine | None = None) -> np.ndarray:
    """(M,) bool: whether CC row `point[k]` may be cut at (`lead[k]`, `tilt[k]`) (rad): the
    machine reaches the axis (`machine` None: any) and `judge` (`poses.PoseJudge`) finds no
    finding there."""
    axes = axes_from_angles(frames, lead, tilt, point)
    ok = np.ones(len(point), bool) if machine is None else np.asarray(machine(axes), bool)
    rows = np.flatnonzero(ok)
    ok[rows] = judge(cc[point[rows]], frames.n[point[rows]], axes[rows])
    return ok


def feasible_region(judge, cc: np.ndarray, normals: np.ndarray, feeds: np.ndarray, *,
                    lead_range: tuple[float, float] = (-LIMIT, LIMIT),
                    tilt_range: tuple[float, float] = (-LIMIT, LIMIT), step: float = STEP,
                    tolerance: float = TOLERANCE,
                    machine: Machine | None = None) -> FeasibleRegion:
    """The feasible orientations of the CC points `cc (N, 3)` with unit normals `normals (N, 3)`
    and feed directions `feeds (N, 3)` (mm, part frame) for the tool of `judge`
    (`poses.PoseJudge`): the grid of `step` (rad) over `lead_range` x `tilt_range` (rad, the
    machine's limits in the CC frame; `machine` further limits the axes), then every boundary
    edge bisected to `tolerance` (rad). See `FeasibleRegion`."""
    cc = np.asarray(cc, dtype=float).reshape(-1, 3)
    frames = local_frames(normals, feeds)
    leads, tilts = angle_grid(*lead_range, step), angle_grid(*tilt_range, step)
    n, nl, nt = len(cc), len(leads), len(tilts)
    point = np.repeat(np.arange(n), nl * nt)
    lead = np.tile(np.repeat(leads, nt), n)
    tilt = np.tile(tilts, n * nl)
    mask = feasible_at(judge, cc, frames, point, lead, tilt, machine).reshape(n, nl, nt)
    k, a, b = _boundary_edges(mask)
    pa = np.column_stack([leads[a[:, 0]], tilts[a[:, 1]]])
    pb = np.column_stack([leads[b[:, 0]], tilts[b[:, 1]]])
    lo, hi = np.zeros(len(k)), np.ones(len(k))
    width = np.linalg.norm(pb - pa, axis=1)
    while len(k) and float(np.max((hi - lo) * width)) > tolerance:
        mid = 0.5 * (lo + hi)
        p = pa + mid[:, None] * (pb - pa)
        ok = feasible_at(judge, cc, frames, k, p[:, 0], p[:, 1], machine)
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    crossing = pa + lo[:, None] * (pb - pa)
    return FeasibleRegion(leads, tilts, mask, k, a, b, crossing, float(tolerance))


def _boundary_edges(mask: np.ndarray):
    """The grid edges whose ends differ: (point (K,), feasible end (K, 2), infeasible end
    (K, 2)) in grid indices, edges along the lead first, then along the tilt."""
    parts = []
    for axis, shift in ((1, np.array([1, 0])), (2, np.array([0, 1]))):
        first = mask[:, :-1, :] if axis == 1 else mask[:, :, :-1]
        second = mask[:, 1:, :] if axis == 1 else mask[:, :, 1:]
        p, i, j = np.nonzero(first != second)
        lo = np.column_stack([i, j])
        hi = lo + shift
        in_lo = first[p, i, j]
        parts.append((p, np.where(in_lo[:, None], lo, hi), np.where(in_lo[:, None], hi, lo)))
    return (np.concatenate([q[0] for q in parts]).astype(np.int64),
            np.concatenate([q[1] for q in parts]).astype(np.int64).reshape(-1, 2),
            np.concatenate([q[2] for q in parts]).astype(np.int64).reshape(-1, 2))
