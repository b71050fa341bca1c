"""The advice stage: at the written program's cutting poses that touch the part, the contact
(CL -> CC), the allowable cutter (the largest of the real cutter's family that neither gouges
nor interferes), its limiting point and the margin, and for planned 4-axis operations the best
table angle and the feasible B intervals; at holder hits the stick-out that clears the holder;
and the cutting poses whose contact the cutter cannot touch (`inaccessible`). Advice about a
pose, never a finding (MATH.md §2-§6, §8): the verdicts are the check's
(`checker.check.verified`), and the advice never calls the real cutter unsafe where the check
finds it clean. NURBS parts go through the allowable-cutter engine (`checker.engine`), mesh
parts through the exact triangle tests (`checker.mesh.allowable.allowable_on_mesh`). Part frame,
mm, degrees."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker import verdict as vd
from checker.check.context import JobContext
from checker.check.program import Program
from checker.check.verified import Verified, pose_of_rows
from checker.cutter import Cutter
from checker.tool_library import largest_standard

_MESH_SIZE_CAP = 4.0  # mesh parts: allowable sizes are searched up to this many real sizes
_MESH_SIZE_TOL = 1e-4  # mm: and bisected to this
_TOUCH = 0.05  # mm: cutting poses this near the part touch it (advice is given for them)


@dataclass
class Advice:
    """Per motion row (N): `cc (N, 3)` the contact point and `normal (N, 3)` the part's normal
    there (mm, part frame), `cc_surface (N,)` its surface (-1: none or a mesh), `size (N,)` the
    allowable cutter's size (mm, the family's size variable: R for flat and bull-nose, r for
    ball), `limiting (N, 3)` the point that limits it and `limiting_surface (N,)` its surface,
    `margin (N,)` the allowable size minus the real one (mm), `inaccessible (N,)` contacts the
    cutter cannot touch; for planned 4-axis operations `b_original`, `b_best` (degrees),
    `at_best` the allowable size at the best B (mm) and `feasible` the feasible B intervals
    (degrees; None elsewhere). nan and -1 where no advice is given (rows that are not cutting
    poses touching the part). Per pose of the written program (P): `pose_verdict (P,)` its
    verdict with the inaccessible contacts marked, `holder_clearance (P,)` at holder hits the
    stick-out that clears the holder (mm, nan elsewhere). For the job: `largest_safe` the
    smallest allowable size over the poses the cutter can reach (mm), `worst_margin` the
    smallest margin there, `largest_standard` the largest cutter of the shipped library in
    the first cutting operation's family that fits (None where there is none)."""

    cc: np.ndarray
    normal: np.ndarray
    cc_surface: np.ndarray
    size: np.ndarray
    limiting: np.ndarray
    limiting_surface: np.ndarray
    margin: np.ndarray
    inaccessible: np.ndarray
    b_original: np.ndarray
    b_best: np.ndarray
    at_best: np.ndarray
    feasible: list
    pose_verdict: np.ndarray | None = None
    holder_clearance: np.ndarray | None = None
    largest_safe: float | None = None
    worst_margin: float | None = None
    largest_standard: str | None = None

    @staticmethod
    def empty(n: int) -> Advice:
        """No advice at `n` motion rows."""
        return Advice(
            cc=np.full((n, 3), np.nan), normal=np.full((n, 3), np.nan),
            cc_surface=np.full(n, -1, dtype=np.int64), size=np.full(n, np.nan),
            limiting=np.full((n, 3), np.nan), limiting_surface=np.full(n, -1, dtype=np.int64),
            margin=np.full(n, np.nan), inaccessible=np.zeros(n, dtype=bool),
            b_original=np.full(n, np.nan), b_best=np.full(n, np.nan),
            at_best=np.full(n, np.nan), feasible=[None] * n)

    def given(self, row: int) -> bool:
        """Whether there is advice at motion row `row` (a size, or at least a contact)."""
        return bool(np.isfinite(self.size[row]) | np.isfinite(self.cc[row]).all())



def advise(job: JobContext, program: Program) -> Advice:
    """The advice at the written program's cutting poses that touch the part (within twice
    their tolerance or _TOUCH mm; see the module docstring)."""
    m = job.m
    out = Advice.empty(len(m))
    w = program.written
    at = pose_of_rows(w.moves, np.arange(len(m)))
    touching = w.poses.depth[at] > -np.maximum(2.0 * w.tolerance[at], _TOUCH)
    for o, c in job.cutters.items():
        rows = job.cutting_rows(np.flatnonzero((m.op == o) & touching))
        if rows.size == 0:
            continue
        tips, axes = program.tip[rows], program.axis[rows]
        if job.part.surfaces:
            _engine_advice(job, program, o, c, rows, tips, axes, out)
        else:
            _mesh_advice(job, program, c, rows, tips, axes, out)
        _clean_is_safe(out, rows, w.pose_verdict[at[rows]], float(c.size))
    out.pose_verdict = _with_inaccessible(w, out)
    out.holder_clearance = _holder_clearance(job, w, out.pose_verdict)
    reach = np.isfinite(out.size) & ~out.inaccessible
    if reach.any():
        out.largest_safe = float(out.size[reach].min())
        out.worst_margin = float(out.margin[reach].min())
    first = job.cutters[int(m.op[np.flatnonzero(~m.rapid)[0]])]
    out.largest_standard = largest_standard(first, out.largest_safe)
    return out


def _with_inaccessible(w: Verified, advice: Advice) -> np.ndarray:
    """The written program's pose verdicts, `inaccessible` where the pose is clear ("ok"), not
    a canned-cycle hole, and its contact cannot be touched (`checker.verdict`)."""
    pose_verdict = w.pose_verdict.copy()
    access = advice.inaccessible[w.moves.row] & (pose_verdict == "ok")
    pose_verdict[access & ~w.moves.hole] = "inaccessible"
    return pose_verdict


def _clean_is_safe(out: Advice, rows: np.ndarray, verdicts: np.ndarray, real: float) -> None:
    """The advice never calls the real cutter (size `real` mm) unsafe at a pose where the check
    finds it clean: at the `rows` whose pose's verdict (`verdicts`) is no finding, an allowable
    size below the real one (and its margin) is raised to it. The check measures the real tool
    at the pose against the part with the job's tolerance, and its verdict is the one answer;
    the engine's size is that of a cutter tangent at the contact with no depth tolerance, which
    a crease of a fraction of a degree (a B-spline's knot line) brings below any real size.
    Contacts that cannot be touched (`inaccessible`) keep their mark."""
    clean = rows[~vd.is_finding(verdicts) & np.isfinite(out.size[rows])
                 & ~out.inaccessible[rows]]
    out.size[clean] = np.maximum(out.size[clean], real)
    out.margin[clean] = out.size[clean] - real


def _engine_advice(job: JobContext, program: Program, o: int, c: Cutter, rows: np.ndarray,
                   tips: np.ndarray, axes: np.ndarray, out: Advice) -> None:
    """NURBS parts: the contact (the plan's where the operation was re-oriented, else CL -> CC
    at the written pose) and the allowable cutter there (`checker.engine.allowable`); the
    plan's best-B advice at its rows."""
    from checker.engine import allowable
    from checker.geometry.contact import cl_to_cc, contact_from_toolpath

    plan = program.plans.get(o)
    samples = job.test_points()
    hint = None
    if plan is not None and program.handling[o] == "re-oriented":
        # the contact the plan turned the tool about: the CAM's own (CL -> CC at its B)
        pick = np.searchsorted(plan.rows, rows)
        pc = plan.contacts
        con = type(pc)(pc.cc[pick], pc.normal[pick], pc.surface[pick], pc.uv[pick],
                       pc.gap[pick])
        hint = plan.orientations.best.allowable_at_best[pick]  # near the chosen B's: time only
    else:
        given = contact_from_toolpath(job.toolpath, job.m.line[rows])
        con = cl_to_cc(job.part, samples, c, tips, axes, contact=given)
    res = allowable(samples, job.part, c, con.cc, con.normal, axes, cc_surface=con.surface,
                    cc_uv=con.uv, toward=tips - con.cc, config=job.cfg, hint=hint)
    out.cc[rows], out.normal[rows], out.cc_surface[rows] = con.cc, con.normal, con.surface
    out.size[rows], out.limiting[rows] = res.size, res.limiting_point
    out.limiting_surface[rows], out.margin[rows] = res.limiting_surface, res.margin
    out.inaccessible[rows] = res.advice == "inaccessible"
    if plan is not None:
        o_ = plan.orientations
        at = np.searchsorted(rows, plan.rows)
        ok = (at < len(rows)) & (rows[np.minimum(at, len(rows) - 1)] == plan.rows)
        r = plan.rows[ok]
        out.b_original[r], out.b_best[r] = o_.original[ok], o_.best.b_best[ok]
        out.at_best[r] = o_.best.allowable_at_best[ok]
        for k, row in zip(np.flatnonzero(ok), r, strict=True):
            out.feasible[row] = o_.best.feasible[k]


def _mesh_advice(job: JobContext, program: Program, c: Cutter, rows: np.ndarray,
                 tips: np.ndarray, axes: np.ndarray, out: Advice) -> None:
    """Mesh parts: the contact at the pose's nearest point of the part with its triangle's
    normal, and the allowable cutter by the exact triangle tests, searched up to
    _MESH_SIZE_CAP times the real size (larger is unbounded); contacts facing away from the
    tool axis are inaccessible."""
    from checker.mesh.allowable import allowable_on_mesh

    w = program.written
    at = pose_of_rows(w.moves, rows)
    point = w.poses.point[at]
    tri = w.poses.triangle[at]
    touching = (tri >= 0) & np.isfinite(point).all(axis=1)
    nrm = np.full((len(rows), 3), np.nan)
    V, T = job.triangles.vertices, job.triangles.triangles
    t = tri[touching]
    n = np.cross(V[T[t, 1]] - V[T[t, 0]], V[T[t, 2]] - V[T[t, 0]])
    nrm[touching] = n / np.linalg.norm(n, axis=1)[:, None]
    facing = touching & (np.einsum("ij,ij->i", np.nan_to_num(nrm), axes) > 1e-9)
    out.cc[rows[touching]], out.normal[rows[touching]] = point[touching], nrm[touching]
    if facing.any():
        size = allowable_on_mesh(job.index, c, point[facing], nrm[facing], axes[facing],
                                 tol=float(w.tolerance[at][facing].max()),
                                 s_max=_MESH_SIZE_CAP * float(c.size), s_tol=_MESH_SIZE_TOL)
        r = rows[facing]
        out.size[r] = size
        out.margin[r] = size - float(c.size)
    out.inaccessible[rows[touching & ~facing]] = True


def _holder_clearance(job: JobContext, w: Verified, verdicts: np.ndarray) -> np.ndarray:
    """Per pose: at holder hits, the stick-out that clears the holder (mm; advice, from the
    part's triangle vertices), nan elsewhere."""
    from checker.four_axis.holder import check_holder
    from checker.four_axis.over_b import holder_of

    out = np.full(len(verdicts), np.nan)
    hit = np.flatnonzero(verdicts == "holder")
    for o in np.unique(job.m.op[w.moves.row[hit]]):
        spec = holder_of(job.cutters[int(o)])
        if spec is None:
            continue
        mine = hit[job.m.op[w.moves.row[hit]] == o]
        got = check_holder(job.triangles.vertices, w.moves.tip[mine], w.moves.axis[mine], **spec)
        out[mine] = got.required_stickout
    return out
