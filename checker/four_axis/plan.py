"""The 4-axis plan of a path: per CC point the allowable size as a function of the table angle B,
the best B and the feasible B intervals for the real cutter; along the path the B chosen by the
shortest path (and the seed-002 greedy smoothing beside it); and the checks of the real cutter at
the chosen B: at every CC point, at the intermediate poses the machine passes through between
them, and for the shank and holder. Part frame, mm, degrees.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.config import Config
from checker.four_axis.axes import axis_for_b
from checker.four_axis.best_b import BestB, best_b
from checker.four_axis.holder import HolderCheck, check_holder
from checker.four_axis.orientation import (
    Orientation,
    greedy_smoothing,
    interval_optima,
    shortest_path_orientation,
    total_rotation,
)
from checker.four_axis.poses import Poses, intermediate_poses


@dataclass(frozen=True)
class Orientations:
    """B per CC point: the CAM's, the best, the chosen (shortest path) and the greedy one."""

    original: np.ndarray
    best: BestB
    chosen: Orientation
    greedy: Orientation

    @property
    def original_rotation(self) -> float:
        return total_rotation(self.original)


def _take(a: np.ndarray | None, rows: np.ndarray) -> np.ndarray | None:
    return None if a is None else a[rows]


def coarse_config(cfg: Config) -> Config:
    """The engine with one refinement start and step per row: sizes a little above the exact
    ones (upper bounds), for scanning B."""
    engine = cfg.engine.model_copy(update={"refine_seeds": 1, "refine_iterations": 1})
    return cfg.model_copy(update={"engine": engine})


def allowable_over_b(test_points, part, cutter, contacts, cfg: Config):
    """`fn(rows, b_deg) -> sizes` for the best-B search: the engine's allowable size of CC
    point `rows` at table angle `b_deg`; 0 where the point faces away from that axis.
    `contacts` has `cc`, `normal` (N, 3) and `surface`, `uv` (None when unknown)."""
    from checker.engine import allowable

    def fn(rows: np.ndarray, b_deg: np.ndarray) -> np.ndarray:
        axes = axis_for_b(b_deg)
        sizes = np.zeros(len(rows))
        facing = np.einsum("ij,ij->i", contacts.normal[rows], axes) > 1e-12
        if facing.any():
            r = rows[facing]
            res = allowable(test_points, part, cutter, contacts.cc[r], contacts.normal[r],
                            axes[facing], cc_surface=_take(contacts.surface, r),
                            cc_uv=_take(contacts.uv, r), config=cfg)
            sizes[facing] = res.size
        return sizes

    return fn


def plan_orientations(
    fn,
    coarse_fn,
    b_original: np.ndarray,
    path_length: np.ndarray,
    required: float,
    cfg: Config,
    b_range: tuple[float, float],
) -> Orientations:
    """Best B and feasible intervals of every CC point (`fn` exact, `coarse_fn` its cheaper
    upper bound for the scan), then the shortest-path and greedy orientations inside them.
    `b_original` (N,) the CAM's B (nan: none), `path_length` (N,) mm of the step arriving at
    each point, `required` the size the real cutter needs (mm)."""
    fa = cfg.four_axis
    n = len(b_original)
    best = best_b(fn, n, b_min=b_range[0], b_max=b_range[1], coarse_step=fa.b_coarse_step,
                  tolerance=fa.b_tolerance, required=required, reference=b_original,
                  coarse_fn=coarse_fn)
    optima = interval_optima(best.grid, best.samples, best.feasible)
    greedy, _ = greedy_smoothing(optima, best.b_best)
    extra = np.concatenate(optima) if any(len(o) for o in optima) else None
    chosen = shortest_path_orientation(
        best.feasible, b_original, best.b_best, path_length, b_min=b_range[0], b_max=b_range[1],
        grid_step=fa.dp_b_step, w_change=fa.dp_weight_change, w_original=fa.dp_weight_original,
        max_db_per_mm=fa.max_db_per_mm, extra_candidates=extra,
    )
    return Orientations(b_original, best, chosen, greedy)


@dataclass(frozen=True)
class PoseCheck:
    """The real cutter at intermediate poses: the poses, their contact points (`contacts`),
    penetration depth (mm, >= 0), allowable size, verdict and margin."""

    poses: Poses
    contacts: object
    depth: np.ndarray
    size: np.ndarray
    verdict: np.ndarray
    margin: np.ndarray
    limiting_point: np.ndarray
    limiting_surface: np.ndarray


def check_poses(test_points, part, cutter, tips, b_deg, segments, cfg: Config, center) -> PoseCheck:
    """Poses between consecutive cutting blocks (`segments`: indices i of moves i -> i+1), the
    real cutter checked at each: contact, penetration and allowable size."""
    from checker.engine import allowable
    from checker.geometry.contact import cl_to_cc

    poses = intermediate_poses(tips, b_deg, center, max_chord=cfg.intermediate.max_chord,
                               max_db=cfg.intermediate.max_db, moves=segments)
    if len(poses.t) == 0:
        empty = np.zeros(0)
        return PoseCheck(poses, None, empty, empty, np.zeros(0, dtype=object), empty,
                         np.zeros((0, 3)), np.zeros(0, dtype=np.int64))
    con = cl_to_cc(part, test_points, cutter, poses.tip, poses.axis)
    res = allowable(test_points, part, cutter, con.cc, con.normal, poses.axis,
                    cc_surface=con.surface, cc_uv=con.uv, toward=poses.tip - con.cc, config=cfg)
    depth = np.maximum(-con.gap, 0.0)
    verdict = res.verdict.astype(object)
    verdict[(depth > cfg.check.depth_tolerance) & (verdict != "interference")] = "gouge"
    return PoseCheck(poses, con, depth, res.size, verdict, res.margin, res.limiting_point,
                     res.limiting_surface)


def holder_of(cutter) -> dict | None:
    """Shank/holder dimensions of a cutter for `check_holder`, None when it has no holder."""
    if not cutter.holder_diameter or not cutter.stickout:
        return None
    flute = cutter.flute_length or cutter.H or cutter.stickout
    return dict(flute_length=float(flute), stickout=float(cutter.stickout),
                shank_diameter=float(cutter.shank_diameter or cutter.d),
                holder_diameter=float(cutter.holder_diameter),
                holder_length=float(cutter.holder_length or 100.0))


def holder_check(test_points, cutter, tips, axes) -> HolderCheck | None:
    """Shank and holder at the given poses, or None when the cutter carries no holder data."""
    spec = holder_of(cutter)
    if spec is None:
        return None
    return check_holder(test_points.points, tips, axes, **spec)
