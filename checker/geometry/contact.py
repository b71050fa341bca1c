"""CL -> CC: the contact point of a cutter at a CL position (tip, axis) on a part, by the
closest approach between the cutter and the exact NURBS surfaces.

Distance from points to a cutter goes through its core (`checker.cutter_core`, the cutter's
own solid: a core grown by a ball of the corner radius), which also gives the sides' normals
(`core_sides`); nothing here reads the cutter's angles or radii (docs/MATH.md §2).

All inputs in mm in the part frame: tips (N,3), unit axes (N,3) (tip -> spindle), points (N,3).
The contact minimises the core distance over the part: start at the best of the k test points
nearest to the fillet-centre level (or at the CAM's own contact point where the CL file gives
one), then a batched, damped Newton iteration in (u, v) on dist^2 / 2, for all N at once; where
that reaches the core (penetration deeper than r), a steepest descent of the depth inside it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from checker.cutter_core import Core, core_sides, project_to_core, signed_distance, tool_coordinates
from checker.geometry.evaluate import evaluate_mixed, points_mixed
from checker.geometry.newton_uv import newton_steps
from checker.geometry.sampling import TestPoints
from checker.part import Part
from checker.units import mm_per_unit

if TYPE_CHECKING:
    from checker.toolpath import ToolPath

_CANDIDATES = 64       # test points tried per CL position
_ITERATIONS = 100      # Newton steps at most (a sharp corner converges slowly)
_TOL = 1e-10           # mm: stop when the step moves the point less than this
_TIE = 1e-6            # mm: contacts this close in gap are on a shared edge
_TOUCH = 2e-3  # mm: a candidate this close to the cutter surface is touched by it
_CORNER = 1e-3         # mm: inside the core, both sides count as nearest within this
_REACHED = 1e-4        # mm: phase 1 ending this near the core goes on to look inside it
_NUM = r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*"
_CONTACT_COMMENT = re.compile(f"^{_NUM},{_NUM},{_NUM}$")


@dataclass
class Contacts:
    """Per CL position: `cc (N,3)` the contact point on the part (mm, part frame), `normal (N,3)`
    the unit surface normal there (out of the material), `surface (N,)` its surface id (-1 on a
    mesh part), `uv (N,2)` its parameters (nan on a mesh part), `gap (N,)` mm the signed
    clearance between the cutter and the part (negative: the cutter penetrates that deep; exact
    for penetrations up to the corner radius r; deeper, and for sharp corners (r = 0), the
    deepest point a local descent inside the cutter finds: a lower bound of the depth)."""

    cc: np.ndarray
    normal: np.ndarray
    surface: np.ndarray
    uv: np.ndarray
    gap: np.ndarray


def cl_to_cc(part: Part, test_points: TestPoints, cutter, tips: np.ndarray, axes: np.ndarray,
             contact: np.ndarray | None = None) -> Contacts:
    """Contact points of `cutter` (a `Cutter`: r, R, psi, theta) at CL positions `tips (N,3)`,
    unit `axes (N,3)` on `part`, sampled as `test_points`. `contact (N,3)`: CC points the CL file
    gives (rows of nan where it gives none) used as starting points.

    Each position is refined from its best starting test point and, where the candidates
    include another surface, from the best one on that surface too (a contact near a surface
    edge may belong to the neighbour). The contact is the candidate the cutter touches (|gap| <=
    _TOUCH mm), else the deepest; `gap` is always the deepest candidate's. A refined point that
    leaves a surface's trim falls back to its starting test point."""
    tips = np.ascontiguousarray(tips, dtype=np.float64).reshape(-1, 3)
    axes = np.ascontiguousarray(axes, dtype=np.float64).reshape(-1, 3)
    axes = axes / np.linalg.norm(axes, axis=1)[:, None]
    core = cutter.core
    if len(tips) == 0:
        z3 = np.zeros((0, 3))
        return Contacts(z3, z3, np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0))
    first, second = _start(test_points, core, tips, axes, contact)
    if part.mesh is not None or len(part.surfaces) == 0:
        pts = test_points.points[first]
        gap = signed_distance(core, pts, tips, axes)
        sid = test_points.surface[first].astype(np.int64)
        return Contacts(pts, test_points.normals[first], sid, test_points.uv[first], gap)
    rows = np.r_[np.arange(len(tips)), np.flatnonzero(second >= 0)]
    start = np.r_[first, second[second >= 0]]
    sid = test_points.surface[start].astype(np.int64)
    uv = _refine(part, core, tips[rows], axes[rows], sid, test_points.uv[start].copy())
    uv = _keep_trimmed(part, sid, uv, test_points.uv[start])
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1])
    proj = project_to_core(core, ev.points, tips[rows], axes[rows])
    gap = proj.gap
    align = _alignment(ev.points, ev.normals, proj.q, axes[rows])
    deepest = _pick(rows, gap, align)
    # the contact is the surface the cutter touches; where it also cuts into another one, that
    # penetration is the gap (a CL point on a blade that digs into the hub touches the blade)
    touch = _pick(rows, np.where(np.abs(gap) <= _TOUCH, np.abs(gap), 1e9 + gap), align)
    return Contacts(ev.points[touch], ev.normals[touch], sid[touch], uv[touch], gap[deepest])


def _alignment(p: np.ndarray, n: np.ndarray, q: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """How well each surface normal agrees with the cutter's own contact normal (the direction
    from the part point to the nearest core point; the axis where they coincide)."""
    d = q - p
    dn = np.linalg.norm(d, axis=1)
    d = np.where(dn[:, None] > 1e-12, d / np.where(dn > 1e-12, dn, 1.0)[:, None], axes)
    return np.einsum("ij,ij->i", n, d)


def _pick(rows: np.ndarray, gap: np.ndarray, align: np.ndarray) -> np.ndarray:
    """Per CL position the candidate of least gap; among candidates within _TIE mm of it (a
    contact on an edge shared by two surfaces) the one whose normal agrees best with the
    cutter's contact normal."""
    gmin = np.full(rows.max() + 1, np.inf)
    np.minimum.at(gmin, rows, gap)
    key = np.where(gap <= gmin[rows] + _TIE, -align, np.inf)
    order = np.lexsort((np.arange(len(rows)), key, rows))
    return order[np.r_[True, rows[order][1:] != rows[order][:-1]]]


def _start(tp: TestPoints, core: Core, tips, axes, contact) -> tuple[np.ndarray, np.ndarray]:
    """Starting test points per CL position: the nearest to the given CC point, else the one of
    least signed distance among the k nearest to the fillet-centre level; and the best of those
    k on another surface (-1 where there is none)."""
    n, k = len(tips), min(_CANDIDATES, len(tp.points))
    _, idx = tp.tree.query(tips + core.h_o * axes, k=k)
    idx = idx.reshape(n, k)
    sd = signed_distance(core, tp.points[idx.ravel()], np.repeat(tips, k, 0),
                         np.repeat(axes, k, 0)).reshape(n, k)
    best = idx[np.arange(n), np.argmin(sd, axis=1)]
    if contact is not None:
        contact = np.asarray(contact, dtype=np.float64).reshape(-1, 3)
        given = np.isfinite(contact).all(axis=1)
        if given.any():
            best[given] = tp.tree.query(contact[given])[1]
    other = tp.surface[idx] != tp.surface[best][:, None]
    sd_other = np.where(other, sd, np.inf)
    j = np.argmin(sd_other, axis=1)
    second = np.where(np.isfinite(sd_other[np.arange(n), j]), idx[np.arange(n), j], -1)
    return best, second


def _keep_trimmed(part: Part, sid: np.ndarray, uv: np.ndarray, uv_start: np.ndarray) -> np.ndarray:
    """Refined parameters, or the starting ones where the refined point is trimmed away."""
    out = uv.copy()
    for s in part.surfaces:
        if s.trim is None:
            continue
        rows = np.flatnonzero(sid == s.id)
        lost = rows[~s.trim.contains(uv[rows, 0], uv[rows, 1])]
        out[lost] = uv_start[lost]
    return out


def _distance_model(core: Core, points, tips, axes, J=None):
    """Phase 1: f = dist(P, core)^2 / 2, its gradient and Hessian with respect to P."""
    proj = project_to_core(core, points, tips, axes)
    return 0.5 * proj.dist**2, points - proj.q, proj.hess


def _depth_model(core: Core, points, tips, axes, J=None):
    """Phase 2, inside the core: f = the signed distance, i.e. minus the depth below the nearer
    of the core's two sides, and its steepest-descent gradient (no Hessian: f is a max): the
    nearer side's normal; where both sides are about as near (within _CORNER), the combination
    of the two normals whose part along the surface (tangent plane spanned by J (K,3,2)) is
    shortest."""
    h, rho, w = tool_coordinates(points, tips, axes)
    proj = project_to_core(core, points, tips, axes)
    if J is None:
        return proj.signed, None, None
    n1, n3, s1, s3 = core_sides(core, h, rho, w, axes)
    G = np.einsum("kia,kib->kab", J, J)
    # the projector onto the tangent plane; pinv where a parameter direction degenerates
    # (a pole, a collapsed edge: du or dv = 0 makes G singular)
    tangential = J @ np.linalg.pinv(G) @ np.swapaxes(J, 1, 2)              # (K,3,3)
    p1 = np.einsum("kij,kj->ki", tangential, n1)
    p3 = np.einsum("kij,kj->ki", tangential, n3)
    diff = p3 - p1
    lam = np.clip(np.einsum("ki,ki->k", p3, diff) / np.maximum(np.einsum("ki,ki->k", diff, diff),
                                                                1e-30), 0.0, 1.0)
    lam = np.where(s1 > s3 + _CORNER, 1.0, np.where(s3 > s1 + _CORNER, 0.0, lam))
    grad = lam[:, None] * n1 + (1 - lam)[:, None] * n3
    return proj.signed, grad, None


def _refine(part: Part, core: Core, tips, axes, sid, uv) -> np.ndarray:
    """Damped Newton in (u, v) per row, inside each domain (wrapping around where a surface is
    closed, e.g. at the seam of a revolved surface): first on the squared distance to the core;
    then, where that reaches the core (the cutter penetrates deeper than r, or r = 0), on the
    signed depth inside it, so that the deepest point is found."""
    dom = np.array([[s.domain[0], s.domain[1]] for s in part.surfaces])       # (S, 2, 2)
    lo, hi = dom[sid, :, 0], dom[sid, :, 1]
    closed = _closed(part)[sid]
    args = (part, core, tips, axes, sid, lo, hi, closed)
    rows = np.arange(len(tips))
    uv = _descend(*args, uv, rows, _distance_model)
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1])
    touching = np.flatnonzero(project_to_core(core, ev.points, tips, axes).dist < _REACHED)
    if touching.size:
        uv = _descend(*args, uv, touching, _depth_model)
    return uv


def _descend(part, core, tips, axes, sid, lo, hi, closed, uv, rows, model) -> np.ndarray:
    """Minimise model's f(S(u, v)) for `rows`: projected Newton steps (newton_uv.py; the
    Gauss-Newton matrix where the Hessian is not positive definite), kept on the domain,
    halved until f decreases; a row stops when its step no longer moves it or no
    halving decreases f."""
    active = np.zeros(len(tips), dtype=bool)
    active[rows] = True
    for _ in range(_ITERATIONS):
        a = np.flatnonzero(active)
        if a.size == 0:
            break
        ev = evaluate_mixed(part, sid[a], uv[a, 0], uv[a, 1], order=2)
        J = np.stack([ev.du, ev.dv], axis=2)                                   # (K,3,2)
        f, d, hp = model(core, ev.points, tips[a], axes[a], J)
        g = np.einsum("kij,ki->kj", J, d)
        if hp is None:          # steepest descent (of a max of two functions)
            H = np.einsum("kia,kib->kab", J, J)
        else:
            H = np.einsum("kia,kij,kjb->kab", J, hp, J)
            H[:, 0, 0] += np.einsum("ki,ki->k", d, ev.duu)
            H[:, 0, 1] += np.einsum("ki,ki->k", d, ev.duv)
            H[:, 1, 1] += np.einsum("ki,ki->k", d, ev.dvv)
            H[:, 1, 0] = H[:, 0, 1]
        step = newton_steps(g, _positive_definite(H, J), uv[a], lo[a], hi[a], closed[a])
        small = np.linalg.norm(np.einsum("kij,kj->ki", J, step), axis=1) < _TOL
        t = np.ones(a.size)
        pending = ~small
        improved = np.zeros(a.size, dtype=bool)
        for _ in range(30):
            p = np.flatnonzero(pending)
            if p.size == 0:
                break
            ap = a[p]
            trial = _inside(uv[ap] + t[p, None] * step[p], lo[ap], hi[ap], closed[ap])
            pts = points_mixed(part, sid[ap], trial[:, 0], trial[:, 1])
            f_new = model(core, pts, tips[ap], axes[ap])[0]
            ok = f_new <= f[p]
            uv[ap[ok]] = trial[ok]
            improved[p[ok]] = f_new[ok] < f[p[ok]]
            pending[p[ok]] = False
            t[p[~ok]] *= 0.5
        active[a] = improved
    return uv


def _closed(part: Part) -> np.ndarray:
    """(S, 2) bool: whether each surface closes on itself in u and in v (its two opposite
    boundary curves coincide), so that a parameter step may wrap around."""
    out = np.zeros((len(part.surfaces), 2), dtype=bool)
    t = np.linspace(0.0, 1.0, 7)
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        vv, uu = v0 + (v1 - v0) * t, u0 + (u1 - u0) * t
        pu = points_mixed(part, np.full(14, s.id), np.r_[np.full(7, u0), np.full(7, u1)],
                          np.r_[vv, vv])
        pv = points_mixed(part, np.full(14, s.id), np.r_[uu, uu],
                          np.r_[np.full(7, v0), np.full(7, v1)])
        size = np.ptp(s.ctrlpts.reshape(-1, 3), axis=0).max()
        out[s.id] = [np.abs(pu[:7] - pu[7:]).max() < 1e-9 * size,
                     np.abs(pv[:7] - pv[7:]).max() < 1e-9 * size]
    return out


def _inside(uv: np.ndarray, lo: np.ndarray, hi: np.ndarray, closed: np.ndarray) -> np.ndarray:
    """Parameters brought into the domain: wrapped in closed directions, else clamped."""
    wrapped = lo + np.mod(uv - lo, hi - lo)
    return np.where(closed, wrapped, np.clip(uv, lo, hi))


def _positive_definite(H: np.ndarray, J: np.ndarray) -> np.ndarray:
    """H where it is positive definite, else the first fundamental form J^T J (a Gauss-Newton
    matrix: its Newton step is a descent direction)."""
    det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] ** 2
    G = np.einsum("kia,kib->kab", J, J)
    scale = np.trace(G, axis1=1, axis2=2)
    pd = (H[:, 0, 0] > 1e-12 * scale) & (det > 1e-12 * scale**2)
    return np.where(pd[:, None, None], H, G + 1e-12 * scale[:, None, None] * np.eye(2))


def contact_from_toolpath(toolpath: ToolPath, lines: np.ndarray) -> np.ndarray:
    """CC points (N,3) mm, part frame, that the CAM wrote for the motions on file `lines` (N,),
    nan rows where it wrote none. Siemens NX in "centerline and contact point" mode writes the
    contact as an inline comment, `GOTO/x,y,z[,i,j,k] $$ cx,cy,cz`, in the file's units and
    frame; the frame in force at a line (the last `CSYS/`/`MSYS/` before it) is applied."""
    lines = np.asarray(lines, dtype=np.int64).ravel()
    found = {}
    for rec in toolpath.records:
        if rec.word == "GOTO" and rec.comment:
            m = _CONTACT_COMMENT.match(rec.comment)
            if m:
                found[rec.line] = [float(x) for x in m.groups()]
    out = np.full((len(lines), 3), np.nan)
    if not found:
        return out
    raw = np.array([found.get(int(n), [np.nan] * 3) for n in np.unique(lines)])
    out = raw[np.searchsorted(np.unique(lines), lines)]
    out *= mm_per_unit(toolpath.units)
    frames = toolpath.frames
    mats = np.stack([np.eye(4)] + [f.matrix if f.applied else np.eye(4) for f in frames])
    which = np.searchsorted(np.array([f.line for f in frames], dtype=np.int64), lines)
    M = mats[which]                     # 0: before any frame (identity)
    return np.einsum("nij,nj->ni", M[:, :3, :3], out) + M[:, :3, 3]
