"""The best orientation per CC point inside its feasible region (docs/MATH.md §10.4), by a
stated objective (a score, larger is better): `allowable_objective` (the largest allowable
cutter at that axis, the engine) or `cusp_objective` (Jun, Lee and Cha 2002: the least cusp height
for a step-over). Scores within `flat` of the best are a tie, broken by the angle to a reference
axis (the CAM's, else the normal): where the objective does not depend on the orientation (a ball's
cusp on its sphere, a size fixed by the curvature) the answer is the feasible axis nearest the
reference. Candidates: the feasible grid nodes and the boundary crossings (Jun, Lee and Cha 2002,
property 3: the optimum often lies on the boundary); the best is refined by a compass search in
(lead, tilt) that only steps to feasible orientations, all points together. Radians, part frame,
mm."""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from checker.five_axis.cusp import cusp_heights
from checker.five_axis.feasible import FeasibleRegion, Machine, feasible_at
from checker.five_axis.lead_tilt import Frames, axes_from_angles, local_frames

Objective = Callable[[np.ndarray, np.ndarray], np.ndarray]  # (point (M,), axes (M, 3)) -> (M,)


class Best(NamedTuple):
    """Per CC point (N,): `lead`, `tilt` (rad) and `axis (N, 3)` of the best feasible
    orientation, `score` the objective there, `angle` (rad) from the reference axis; nan (and
    `found` False) where no orientation is feasible."""

    lead: np.ndarray
    tilt: np.ndarray
    axis: np.ndarray
    score: np.ndarray
    angle: np.ndarray
    found: np.ndarray


def allowable_objective(test_points, part, cutter, cc: np.ndarray, normals: np.ndarray,
                        config=None) -> Objective:
    """Score = the allowable size (mm, `checker.engine.allowable`, inf unbounded) of `cutter`'s
    family at CC row `point` with that axis."""
    from checker.engine import allowable

    def score(point: np.ndarray, axes: np.ndarray) -> np.ndarray:
        if len(point) == 0:
            return np.zeros(0)
        return allowable(test_points, part, cutter, cc[point], normals[point], axes,
                         config=config).size
    return score


def cusp_objective(cutter, frames: Frames, stepover: float,
                   curvature: np.ndarray | float = 0.0) -> Objective:
    """Score = minus the cusp height (mm) for `stepover` (`cusp.cusp_heights`)."""
    def score(point: np.ndarray, axes: np.ndarray) -> np.ndarray:
        return -cusp_heights(cutter, frames, point, axes, stepover, curvature)
    return score


def best_orientation(region: FeasibleRegion, judge, cc: np.ndarray, normals: np.ndarray,
                     feeds: np.ndarray, objective: Objective, *,
                     reference: np.ndarray | None = None, flat: float = 1e-6,
                     machine: Machine | None = None, max_rounds: int = 60) -> Best:
    """The best orientation of each CC point of `region` (found by `feasible_region` with the
    same `judge`, CC points, normals, feeds and `machine`) by `objective` (module docstring),
    ties within `flat` broken by the angle to `reference (N, 3)` (None: the normal); the
    compass search stops at the region's angle tolerance."""
    cc = np.asarray(cc, dtype=float).reshape(-1, 3)
    fr = local_frames(normals, feeds)
    n = len(cc)
    ref = fr.n if reference is None else np.asarray(reference, dtype=float).reshape(n, 3)
    ref = ref / np.linalg.norm(ref, axis=1)[:, None]
    lo = np.array([region.leads[0], region.tilts[0]])
    hi = np.array([region.leads[-1], region.tilts[-1]])
    p, i, j = np.nonzero(region.mask)
    pts = np.concatenate([p, region.edge_point])
    ang = np.concatenate([np.column_stack([region.leads[i], region.tilts[j]]), region.crossing])
    score, angle = _evaluate(objective, fr, ref, pts, ang)
    first = _choose(pts, score, angle, flat, n)
    found = first >= 0
    at, cur_s, cur_a = np.full((n, 2), np.nan), np.full(n, np.nan), np.full(n, np.nan)
    at[found], cur_s[found], cur_a[found] = ang[first[found]], score[first[found]], \
        angle[first[found]]
    top = cur_s.copy()  # ties are judged against the best score seen: no drift down a slope
    step = np.where(found, 0.5 * max(_spacing(region.leads), _spacing(region.tilts)), 0.0)
    moves = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    for _ in range(max_rounds):
        live = np.flatnonzero(step >= region.tolerance)
        if live.size == 0:
            break
        k = np.repeat(live, 4)
        cand = np.clip(at[k] + np.tile(moves, (len(live), 1)) * step[k, None], lo, hi)
        ok = feasible_at(judge, cc, fr, k, cand[:, 0], cand[:, 1], machine)
        s, a = np.full(len(k), -np.inf), np.full(len(k), np.inf)
        s[ok], a[ok] = _evaluate(objective, fr, ref, k[ok], cand[ok])
        better = ok & _better(s, a, top[k], cur_a[k], flat)
        pick = _choose(np.where(better, k, -1), s, a, flat, n)
        moved = pick >= 0
        at[moved], cur_s[moved], cur_a[moved] = cand[pick[moved]], s[pick[moved]], \
            a[pick[moved]]
        top[moved] = np.maximum(top[moved], cur_s[moved])
        step[live[~moved[live]]] *= 0.5
    axis = np.full((n, 3), np.nan)
    axis[found] = axes_from_angles(fr, at[found, 0], at[found, 1], np.flatnonzero(found))
    return Best(at[:, 0], at[:, 1], axis, cur_s, cur_a, found)


def _spacing(grid: np.ndarray) -> float:
    return float(grid[1] - grid[0]) if len(grid) > 1 else 0.0


def _evaluate(objective: Objective, fr: Frames, ref: np.ndarray, point: np.ndarray,
              ang: np.ndarray):
    """(score, angle to the reference) of orientations `ang (M, 2)` at CC rows `point`."""
    axes = axes_from_angles(fr, ang[:, 0], ang[:, 1], point)
    cos = np.clip(np.einsum("ij,ij->i", axes, ref[point]), -1.0, 1.0)
    return np.asarray(objective(point, axes), dtype=float), np.arccos(cos)


def _better(s, a, top, a0, flat: float) -> np.ndarray:
    """Whether (score s, angle a) beats the current angle `a0` with `top` the best score seen:
    a score above `top` by more than `flat`, or one within `flat` of it and a smaller angle (by
    more than rounding)."""
    tie = (s == top) | (np.abs(s - top) <= flat)
    return (~tie & (s > top)) | (tie & (a < a0 - 1e-12))


def _choose(point: np.ndarray, score: np.ndarray, angle: np.ndarray, flat: float,
            n: int) -> np.ndarray:
    """Per CC row (n,) the index of its best candidate (`point` -1: not a candidate; -1 where
    it has none): the highest score, then among those within `flat` of it the smallest angle."""
    out = np.full(n, -1)
    valid = point >= 0
    if not valid.any():
        return out
    top = np.full(n, -np.inf)
    np.maximum.at(top, point[valid], score[valid])
    rows = np.flatnonzero(valid)
    t = top[point[rows]]
    tie = (score[rows] == t) | (score[rows] >= t - flat)
    rows = rows[tie]
    order = np.lexsort((angle[rows], point[rows]))
    rows = rows[order]
    head = np.r_[True, point[rows][1:] != point[rows][:-1]]
    out[point[rows[head]]] = rows[head]
    return out
