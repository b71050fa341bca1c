"""Re-orienting one multi-axis operation (docs/MATH.md §10, §13; Jun, Lee and Cha 2002; Hwang et al.
2011): the tool axis along its cutting poses chosen inside each CC point's feasible set, smooth, and
near the CAM's where it may.

Per contact row of the operation (a feed move whose tool touches the part, CL -> CC as the
4-axis plan does it): the CC point, its normal and the feed direction (the next CC point of the
same segment minus this one; the last point of a segment: this minus the previous one). The
feasible set (`feasible.feasible_region`) with the real tool (cutter, shank, holder: the check's
verdict rule) and the machine's reach as the `machine` mask (`machine_reach`: axes the chain
makes within its rotary limits, outside a cone about its singular direction). Candidates: the
grid's nodes plus the CAM's own axis (so that a feasible CAM pose is kept exactly, not moved to
the nearest node); score = minus the angle to the CAM's axis (cheap: a ball's cusp does not
depend on the orientation; the greedy smoothing of Jun, Lee and Cha (2002) then takes, per feasible
region, the axis nearest the CAM's). The least-turn chain (`posture.shortest_posture`, the CAM's
axis preferred, a turn limit per mm), then the MB-spline fairing of Hwang et al. (2011) with the
judge as the oracle. A contact row is a feed move whose CAM tip is the tip touching its contact
(within `five_axis.contact_gap` mm): a move in the air is not one, one that also buries the tool's
body elsewhere is.

The other rows of the operation (approach, retract, rapids, feed moves in the air) follow their
nearest contact row as the 4-axis plan makes them follow: their offset from that row's CAM tip
and their axis turned by the least rotation that takes its CAM axis to the chosen one. The
contact rows, the judge, the reach and the fairing are shared with the contact-order planner
(`contact_plan`, flat-end finishing). Part frame, mm; radians inside, degrees in the config."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from checker.five_axis.feasible import FeasibleRegion, Machine, feasible_region
from checker.five_axis.lead_tilt import Frames, angles_from_axes, axes_from_angles, local_frames
from checker.five_axis.poses import PoseJudge
from checker.five_axis.posture import Candidates, Posture, mb_spline_fairing, shortest_posture


@dataclass
class FivePlan:
    """The plan of one multi-axis operation. Per contact row (N): `rows` (motion rows),
    `contacts` (CL -> CC at the CAM's axis), `frames` (feed, normal, side), `s` path length
    along the CC points (mm), `starts` rows that begin a segment, `region` the feasible sets
    (None: the contact-order planner), `cam_axis` and `cam_feasible` (the CAM's pose judged),
    `planned` (least turn, or the contact-order poses) and `chosen` (faired) postures, `lead`,
    `tilt` (rad) of the chosen axis in the CC frame. Per row of the operation (M): `op_rows`,
    `tip_rows`, `axis_rows` the program to write. `feasible_at(k, axes)`: whether contact rows
    `k` may be cut at `axes` (the machine reaches them and the judge finds nothing), the
    fairing's oracle. `contact`: the contact-order planner's poses (`contact_order.ContactPlan`;
    None: the allowable planner)."""

    rows: np.ndarray
    contacts: object
    frames: Frames
    s: np.ndarray
    starts: np.ndarray
    region: FeasibleRegion | None
    cam_axis: np.ndarray
    cam_feasible: np.ndarray
    planned: Posture
    chosen: Posture
    lead: np.ndarray
    tilt: np.ndarray
    op_rows: np.ndarray
    tip_rows: np.ndarray
    axis_rows: np.ndarray
    feasible_at: Callable[[np.ndarray, np.ndarray], np.ndarray]
    contact: object = None


def machine_reach(chain, *, cone: float, tolerance: float = 1e-3) -> Machine:
    """The axes (M, 3), part frame, that machine `chain` (`checker.postproc.kinematics.Chain`) makes
    within `tolerance` degrees, with at least one solution inside its rotary limits, and, for
    two rotary axes, more than `cone` degrees from the free rotation's axis (its singular
    direction, e.g. C on an A/C trunnion: there C turns by the axis' turn divided by the sine
    of that angle)."""
    lo, hi = chain.limits[:, 0], chain.limits[:, 1]
    narrow = (hi - lo) < 360.0 - 1e-9

    def inside(v: np.ndarray) -> np.ndarray:  # (M, k) -> (M,): a whole turn fits each limit
        m = np.ceil((lo - v) / 360.0 - 1e-9)
        return np.all(~narrow | (v + 360.0 * m <= hi + 1e-9), axis=1)

    def reach(axes: np.ndarray) -> np.ndarray:
        sol = chain.solve(axes)
        ok = (sol.reach <= tolerance) & (inside(sol.joints[:, 0]) | inside(sol.joints[:, 1]))
        return ok & (sol.pole > cone) if chain.k == 2 else ok
    return reach


def contact_segments(rows: np.ndarray) -> np.ndarray:
    """(N,) bool: contact rows that begin a segment (the first, and any after a row that is not
    a contact row: a rapid, an approach, a retract)."""
    return np.r_[True, np.diff(rows) > 1] if len(rows) else np.zeros(0, bool)


def feed_directions(cc: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(N, 3) feed directions: the next CC point of the segment minus this one; the last of a
    segment (or a single point): this minus the previous one (a lone point: +x)."""
    n = len(cc)
    fwd = np.vstack([np.diff(cc, axis=0), np.zeros((1, 3))])
    last = np.r_[starts[1:], True]
    back = np.vstack([np.zeros((1, 3)), np.diff(cc, axis=0)])
    d = np.where(last[:, None], back, fwd)
    lone = last & starts
    d[lone] = [1.0, 0.0, 0.0]
    short = np.linalg.norm(d, axis=1) <= 1e-12
    d[short & ~lone] = np.where(np.arange(n)[short & ~lone, None] > 0, back[short & ~lone],
                                [1.0, 0.0, 0.0])
    return d


def least_rotation(a: np.ndarray, b: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors `v (N, 3)` turned by the least rotation that takes unit `a (N, 3)` to unit
    `b (N, 3)` (Rodrigues about a x b; opposite axes are not turned)."""
    k = np.cross(a, b)
    sin = np.linalg.norm(k, axis=1)
    cos = np.einsum("ij,ij->i", a, b)
    u = np.where(sin[:, None] > 1e-12, k / np.maximum(sin, 1e-300)[:, None], 0.0)
    return (v * cos[:, None] + np.cross(u, v) * sin[:, None]
            + u * np.einsum("ij,ij->i", u, v)[:, None] * (1.0 - cos[:, None]))


def candidates(region: FeasibleRegion, frames: Frames, cam_axis: np.ndarray,
               cam_ok: np.ndarray, with_cam: bool) -> Candidates:
    """The grid's nodes of every point as candidates (`with_cam`: plus the CAM's axis as the
    last column, feasible where `cam_ok`); score = minus the angle to the CAM's axis (rad)."""
    n, nl, nt = region.mask.shape
    point = np.repeat(np.arange(n), nl * nt)
    lead = np.tile(np.repeat(region.leads, nt), n)
    tilt = np.tile(region.tilts, n * nl)
    axes = axes_from_angles(frames, lead, tilt, point).reshape(n, nl * nt, 3)
    feasible = region.mask.reshape(n, -1)
    if with_cam:
        axes = np.concatenate([axes, cam_axis[:, None, :]], axis=1)
        feasible = np.concatenate([feasible, cam_ok[:, None]], axis=1)
    score = -np.arccos(np.clip(np.einsum("ngi,ni->ng", axes, cam_axis), -1.0, 1.0))
    return Candidates(axes, feasible, score, (nl, nt))


@dataclass
class Setting:
    """What every planner of one multi-axis operation shares: the contact `rows` (N,), their
    `cam_axis` (N, 3) unit, `contacts` (CL -> CC at the CAM's axis: cc, normal, surface, uv),
    `starts` (rows that begin a segment), `feeds` (N, 3), `frames`, `s` path length along the
    CC points (mm), the real tool's `judge`, the machine's `reach` (None: any axis),
    `accepted(cc, normals, axes)` (M,) bool (the machine reaches `axes` and the judge finds
    nothing at those CC points), `feasible_at(k, axes)` the same at contact rows `k`, and
    `cam_ok` (the CAM's axis so judged). Part frame, mm, rad."""

    rows: np.ndarray
    cam_axis: np.ndarray
    contacts: object
    starts: np.ndarray
    feeds: np.ndarray
    frames: Frames
    s: np.ndarray
    judge: PoseJudge
    reach: Machine | None
    accepted: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    feasible_at: Callable[[np.ndarray, np.ndarray], np.ndarray]
    cam_ok: np.ndarray


def operation_setting(job, rows: np.ndarray, cutter, tolerance: float, chain,
                      cfg) -> Setting | None:
    """The contact rows of a multi-axis operation and what is judged at them (module
    docstring): `rows` its cutting rows, `tolerance` its penetration allowed (mm), `chain` the
    machine's (None: any axis is reached). None where no cutting row touches the part (a NURBS
    part is needed for CL -> CC)."""
    from checker.geometry.contact import cl_to_cc, contact_from_toolpath

    m, fa = job.m, cfg.five_axis
    if rows.size == 0 or not job.part.surfaces:
        return None
    given = contact_from_toolpath(job.toolpath, m.line[rows])
    cam_axis = m.axis[rows] / np.linalg.norm(m.axis[rows], axis=1)[:, None]
    con = cl_to_cc(job.part, job.test_points(), cutter, m.tip[rows], cam_axis, contact=given)
    # touching: the tool that touches the contact at the CAM's axis is the CAM's (a pose in the
    # air is not; a pose that also buries its body elsewhere is)
    touch = np.linalg.norm(cutter.tip_from_contact(con.cc, con.normal, cam_axis) - m.tip[rows],
                           axis=1) <= fa.contact_gap
    if not touch.any():
        return None
    keep = np.flatnonzero(touch)
    rows, cam_axis = rows[keep], cam_axis[keep]
    con = type(con)(con.cc[keep], con.normal[keep], con.surface[keep], con.uv[keep],
                    con.gap[keep])
    starts = contact_segments(rows)
    feeds = feed_directions(con.cc, starts)
    judge = PoseJudge(job.index, cutter, float(tolerance), job.triangles.deviation,
                      gouge_neighbourhood=cfg.check.gouge_neighbourhood)
    reach = None if chain is None else machine_reach(chain, cone=fa.singular_cone_deg)

    def accepted(cc: np.ndarray, normals: np.ndarray, axes: np.ndarray) -> np.ndarray:
        ok = np.ones(len(cc), bool) if reach is None else np.asarray(reach(axes), bool)
        at = np.flatnonzero(ok)
        ok[at] = judge(cc[at], normals[at], axes[at])
        return ok

    def feasible_at(k: np.ndarray, axes: np.ndarray) -> np.ndarray:
        return accepted(con.cc[k], con.normal[k], axes)

    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(con.cc, axis=0), axis=1))]
    return Setting(rows, cam_axis, con, starts, feeds, local_frames(con.normal, feeds), s,
                   judge, reach, accepted, feasible_at,
                   feasible_at(np.arange(len(rows)), cam_axis))


def plan_operation(job, rows: np.ndarray, op_rows: np.ndarray, cutter, tolerance: float,
                   chain, cfg) -> FivePlan | None:
    """The plan of one multi-axis operation (module docstring): `rows` its cutting rows,
    `op_rows` all its rows, `tolerance` its penetration allowed (mm), `chain` the machine's
    (None: any axis is reached), `cfg` the config. None where no cutting row touches the
    part (a NURBS part is needed for CL -> CC)."""
    fa = cfg.five_axis
    st = operation_setting(job, rows, cutter, tolerance, chain, cfg)
    if st is None:
        return None
    lim_l, lim_t = math.radians(fa.lead_limit_deg), math.radians(fa.tilt_limit_deg)
    region = feasible_region(st.judge, st.contacts.cc, st.contacts.normal, st.feeds,
                             lead_range=(-lim_l, lim_l), tilt_range=(-lim_t, lim_t),
                             step=math.radians(fa.grid_step_deg),
                             tolerance=math.radians(fa.boundary_tolerance_deg), machine=st.reach)
    cand = candidates(region, st.frames, st.cam_axis, st.cam_ok, with_cam=True)
    planned = shortest_posture(cand, st.s, st.cam_axis,
                               max_turn_per_mm=math.radians(fa.max_turn_per_mm_deg),
                               w_pref=fa.preference_weight, starts=st.starts)
    return finish_plan(job, st, op_rows, cutter, planned, cfg, region=region)


def finish_plan(job, st: Setting, op_rows: np.ndarray, cutter, planned: Posture, cfg, *,
                region: FeasibleRegion | None = None, contact: object = None) -> FivePlan:
    """The MB-spline fairing (Hwang et al. 2011) of a planned posture with `st.feasible_at` as the
    oracle, the tips that touch the contacts at the chosen axes (the CAM tip's offset from its
    touching tip kept, turned with the axis) and every row of the operation following its
    nearest contact row; `region` the feasible sets (allowable planner), `contact` the
    contact-order poses (`contact_order.ContactPlan`)."""
    m, con = job.m, st.contacts
    chosen = mb_spline_fairing(planned, st.feasible_at, passes=cfg.five_axis.fairing_passes,
                               starts=st.starts)
    lead, tilt = angles_from_axes(st.frames, chosen.axis)
    cam_tips = cutter.tip_from_contact(con.cc, con.normal, st.cam_axis)
    tips = cutter.tip_from_contact(con.cc, con.normal, chosen.axis) + least_rotation(
        st.cam_axis, chosen.axis, m.tip[st.rows] - cam_tips)
    tip_rows, axis_rows = _follow(m, st.rows, op_rows, st.cam_axis, chosen.axis, tips)
    return FivePlan(st.rows, con, st.frames, st.s, st.starts, region, st.cam_axis, st.cam_ok,
                    planned, chosen, lead, tilt, op_rows, tip_rows, axis_rows, st.feasible_at,
                    contact)


def _follow(m, rows, op_rows, cam_axis, axis, tips):
    """Every row of the operation moved with its nearest contact row (module docstring)."""
    k = np.clip(np.searchsorted(rows, op_rows), 0, len(rows) - 1)
    prev = np.clip(k - 1, 0, len(rows) - 1)
    k = np.where(np.abs(rows[prev] - op_rows) < np.abs(rows[k] - op_rows), prev, k)
    a_old, a_new = cam_axis[k], axis[k]
    tip = tips[k] + least_rotation(a_old, a_new, m.tip[op_rows] - m.tip[rows[k]])
    own = m.axis[op_rows] / np.linalg.norm(m.axis[op_rows], axis=1)[:, None]
    ax = least_rotation(a_old, a_new, own)
    at = np.searchsorted(op_rows, rows)
    tip[at], ax[at] = tips, axis
    return tip, ax / np.linalg.norm(ax, axis=1)[:, None]


def rotary_words(chain, axes: np.ndarray) -> np.ndarray:
    """(N, k) the machine's rotary words (degrees) for unit axes (N, 3), part frame, chosen as
    the post chooses them (`Chain.words_for_axes`: continuous, within the limits)."""
    joints, _, _ = chain.words_for_axes(axes)
    return joints


def rotary_metrics(chain, plan: FivePlan, axes: np.ndarray):
    """`posture.posture_metrics` of the rotary words of `axes (N, 3)` at the plan's contact
    points (per mm of CC path, segments not crossed)."""
    from checker.five_axis.posture import posture_metrics

    return posture_metrics(rotary_words(chain, axes), plan.s, plan.starts)
