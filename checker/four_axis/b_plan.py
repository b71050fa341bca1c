"""The 4-axis plan of an operation (`plan_b`): per cutting pose the best B and the feasible B
intervals of the real cutter from the allowable-cutter engine, the B chosen along the path and
the tips there; and the same best-B advice for `pathcheck allowable`. Part frame, mm,
degrees."""

from __future__ import annotations

import numpy as np

from checker.b_axis import (
    axis_for_b,
    b_for_axis,
    check_b_range,
    check_four_axis,
    rotate_about_y,
)
from checker.config import Config
from checker.engine.grid.bins import drop_table_grids
from checker.four_axis.best_b import best_b
from checker.four_axis.over_b import (
    Orientations,
    OverB,
    allowable_over_b,
    bound_over_b,
    coarse_config,
    facing_edges,
    plan_orientations,
)


def moved_tips(cutter, contacts, tips, b_old: np.ndarray, b_new: np.ndarray) -> np.ndarray:
    """Tool tips at the new table angles: the tip that touches the same contact point at the new
    axis, plus the CL point's offset from the old touching tip turned with the axis (a plunge or
    retract along the axis stays one). (N, 3) part frame, mm."""
    old = cutter.tip_from_contact(contacts.cc, contacts.normal, axis_for_b(b_old))
    new = cutter.tip_from_contact(contacts.cc, contacts.normal, axis_for_b(b_new))
    return new + rotate_about_y(tips - old, b_old - b_new, np.zeros(3))


def plan_b(*, test_points, part, cutter, contacts, tips: np.ndarray, axes: np.ndarray,
           lines: np.ndarray, b_range: tuple[float, float] | None,
           machine_limits: tuple[float, float], path: str,
           cfg: Config) -> tuple[Orientations, np.ndarray, np.ndarray]:
    """The 4-axis plan of one cutter's cutting rows: (orientations, B chosen (N,) degrees, the
    tips at those B (N, 3)). The best B and the feasible intervals come from the engine's
    allowable size over B; the chosen B is the shortest path through them."""
    check_four_axis(axes, lines, path, cfg.four_axis.axis_j_tolerance)
    lo, hi = b_range if b_range is not None else (cfg.four_axis.b_min, cfg.four_axis.b_max)
    check_b_range(lo, hi, *machine_limits)
    b_original = b_for_axis(axes)
    step = np.r_[0.0, np.linalg.norm(np.diff(contacts.cc, axis=0), axis=1)]
    exact = OverB(test_points, part, cutter, contacts, cfg)
    coarse_cfg = coarse_config(cfg)
    coarse = OverB(test_points, part, cutter, contacts, coarse_cfg, exact.last).sizes
    bound = bound_over_b(test_points, part, cutter, contacts, coarse_cfg)
    orientations = plan_orientations(exact.sizes, coarse, b_original, step,
                                     cutter.size + cfg.check.tolerance, cfg, (lo, hi), bound,
                                     searched=lambda: drop_table_grids(test_points),
                                     tracked=exact if exact.tracks else None,
                                     edge_fn=facing_edges(contacts))
    b_chosen = orientations.chosen.b
    return orientations, b_chosen, moved_tips(cutter, contacts, tips, b_original, b_chosen)


def best_b_points(doc: dict, test_points, part, cutter, cc: np.ndarray, normals: np.ndarray,
                  b_range: tuple[float, float], cfg: Config) -> None:
    """Add `b_best`, `allowable_at_best` and `b_feasible` (for `cutter`) to every point of a
    `pathcheck allowable` document, searching B in `b_range` degrees."""
    from types import SimpleNamespace

    check_b_range(*b_range, -360.0, 360.0)
    contacts = SimpleNamespace(cc=cc, normal=normals, surface=None, uv=None)
    fn = allowable_over_b(test_points, part, cutter, contacts, cfg)
    best = best_b(fn, len(cc), b_min=b_range[0], b_max=b_range[1],
                  coarse_step=cfg.four_axis.b_coarse_step, tolerance=cfg.four_axis.b_tolerance,
                  required=cutter.size + cfg.check.tolerance, edge_fn=facing_edges(contacts))
    for i, point in enumerate(doc["points"]):
        point["b_best"] = round(float(best.b_best[i]), 6)
        at = best.allowable_at_best[i]
        point["allowable_at_best"] = round(float(at), 6) if np.isfinite(at) else None
        point["b_feasible"] = [[round(lo, 6), round(hi, 6)] for lo, hi in best.feasible[i]]
