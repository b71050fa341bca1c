"""The path-level checks that `checker.job.check_job` adds to the CC-point check: for 4-axis jobs
(and 3-axis jobs re-oriented for a 4-axis machine) the best B, the feasible B intervals, the B
chosen along the path and the verdicts there; for every job the intermediate poses between
consecutive cutting blocks (thesis 6.2) and the shank/holder at every pose. Part frame, mm,
degrees."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.config import Config
from checker.four_axis.axes import (
    axis_for_b,
    b_for_axis,
    check_b_range,
    check_four_axis,
    rotate_about_y,
)
from checker.four_axis.best_b import best_b
from checker.four_axis.plan import (
    Orientations,
    PoseCheck,
    allowable_over_b,
    check_poses,
    coarse_config,
    holder_check,
    plan_orientations,
)


@dataclass(frozen=True)
class PathChecks:
    """What the path-level checks add. Per CC row (N,): `b_chosen`, `tips_chosen` (N, 3), the
    allowable size / verdict / margin at the chosen B (holder hits there included),
    `holder_clearance` of the CL path as given (nan: no hit); plus the orientations (None for
    3-axis jobs) and the intermediate poses checked."""

    orientations: Orientations | None
    b_chosen: np.ndarray | None
    tips_chosen: np.ndarray
    size_chosen: np.ndarray | None
    verdict_chosen: np.ndarray | None
    margin_chosen: np.ndarray | None
    holder_clearance: np.ndarray
    poses: PoseCheck | None
    pose_holder_clearance: np.ndarray


def segments_of(cut: np.ndarray, ops: np.ndarray) -> np.ndarray:
    """Indices i of cutting rows followed by a cutting row of the next motion in the same
    operation: the moves along which the machine cuts and intermediate poses are checked."""
    if len(cut) < 2:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero((np.diff(cut) == 1) & (np.diff(ops) == 0))


def moved_tips(cutter, contacts, tips, b_old: np.ndarray, b_new: np.ndarray) -> np.ndarray:
    """Tool tips at the new table angles: the tip that touches the same contact point at the new
    axis, plus the CL point's offset from the old touching tip turned with the axis (a plunge or
    retract along the axis stays one). (N, 3) part frame, mm."""
    old = cutter.tip_from_contact(contacts.cc, contacts.normal, axis_for_b(b_old))
    new = cutter.tip_from_contact(contacts.cc, contacts.normal, axis_for_b(b_new))
    return new + rotate_about_y(tips - old, b_old - b_new, np.zeros(3))


def check_path(
    *,
    test_points,
    part,
    cutter,
    contacts,
    tips: np.ndarray,
    axes: np.ndarray,
    lines: np.ndarray,
    segments: np.ndarray,
    four_axis: bool,
    b_range: tuple[float, float] | None,
    machine_limits: tuple[float, float],
    table_center: np.ndarray,
    path: str,
    cfg: Config,
) -> PathChecks:
    """Run the path-level checks for one cutter's rows (see the module docstring)."""
    from checker.engine import allowable

    orientations = b_chosen = size_c = verdict_c = margin_c = None
    tips_chosen = tips
    pose_b = None
    if four_axis:
        check_four_axis(axes, lines, path, cfg.four_axis.axis_j_tolerance)
        lo, hi = b_range if b_range is not None else (cfg.four_axis.b_min, cfg.four_axis.b_max)
        check_b_range(lo, hi, *machine_limits)
        b_original = b_for_axis(axes)
        step = np.r_[0.0, np.linalg.norm(np.diff(contacts.cc, axis=0), axis=1)]
        fn = allowable_over_b(test_points, part, cutter, contacts, cfg)
        coarse = allowable_over_b(test_points, part, cutter, contacts, coarse_config(cfg))
        orientations = plan_orientations(fn, coarse, b_original, step,
                                         cutter.size + cfg.check.tolerance, cfg, (lo, hi))
        b_chosen = orientations.chosen.b
        chosen_axes = axis_for_b(b_chosen)
        tips_chosen = moved_tips(cutter, contacts, tips, b_original, b_chosen)
        res = allowable(test_points, part, cutter, contacts.cc, contacts.normal, chosen_axes,
                        cc_surface=contacts.surface, cc_uv=contacts.uv, config=cfg)
        size_c, verdict_c, margin_c = res.size, res.verdict.astype(object), res.margin
        pose_b = b_chosen
        pose_axes = chosen_axes
    else:
        pose_axes = axes
    holder_clearance = np.full(len(tips), np.nan)
    held = holder_check(test_points, cutter, tips, axes)  # the CL path as given
    if held is not None:
        holder_clearance[held.hit] = held.required_stickout[held.hit]
    if verdict_c is not None:
        held = holder_check(test_points, cutter, tips_chosen, pose_axes)
        if held is not None:
            verdict_c[held.hit & (verdict_c == "ok")] = "holder"
    poses = None
    pose_clearance = np.zeros(0)
    vertical = np.allclose(axes, [0.0, 0.0, 1.0], atol=1e-9)
    if four_axis or vertical:
        b_path = pose_b if pose_b is not None else np.zeros(len(tips))
        poses = check_poses(test_points, part, cutter, tips_chosen, b_path, segments, cfg,
                            table_center)
        pose_clearance = np.full(len(poses.depth), np.nan)
        held = holder_check(test_points, cutter, poses.poses.tip, poses.poses.axis)
        if held is not None and len(poses.depth):
            pose_clearance[held.hit] = held.required_stickout[held.hit]
            poses.verdict[held.hit] = "holder"
    return PathChecks(orientations, b_chosen, tips_chosen, size_c, verdict_c, margin_c,
                      holder_clearance, poses, pose_clearance)


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
                  required=cutter.size + cfg.check.tolerance)
    for i, point in enumerate(doc["points"]):
        point["b_best"] = round(float(best.b_best[i]), 6)
        at = best.allowable_at_best[i]
        point["allowable_at_best"] = round(float(at), 6) if np.isfinite(at) else None
        point["b_feasible"] = [[round(lo, 6), round(hi, 6)] for lo, hi in best.feasible[i]]
