"""`check_job`: the main job shared by the CLI, the service and batch runs. Read the CL file and
the part; per operation decide what to do with it by its axis class (a 3-axis or indexed
operation is checked as programmed; a 4-axis operation gets the best and chosen table angle B
from the allowable-cutter engine, and keeps the CAM's angles where re-orientation does not
remove its findings); then check the program that is written: the real tool at every pose and
along every move (`checker.verify`), one verdict rule (`checker.verdict`); advice at the
cutting poses (contact, allowable cutter, margin); summarise (`check_program` stops here and
returns what is to be written); and, when G-code is asked for, post that program (the posting
stage, `checker.posting`). Part frame, mm, degrees."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker import input_limits, verdict, written
from checker.apt import read_cl
from checker.b_axis import check_four_axis
from checker.check.options import CheckOptions
from checker.collide.section import add_to_document, machine_section
from checker.config import Config
from checker.document import build_document, stock_document
from checker.errors import PathcheckError
from checker.five_axis.motion import MachineMotion
from checker.geometry import find_part_beside, load_part
from checker.geometry.sampling import sample_part
from checker.geometry.tessellate import part_triangles
from checker.geometry.transform import parse_transform, transform_part
from checker.job_inputs import job_config, operation_cutters, part_file
from checker.mesh.bvh import MeshIndex
from checker.posting import post_checked
from checker.postproc.kinematics import Chain
from checker.postproc.post import machine_for_toolpath
from checker.progress import step
from checker.results import ResultsDocument
from checker.stock.check import check_stock
from checker.stock.request import StockRequest
from checker.tolerance import operation_tolerances

_DEFAULTS = CheckOptions()
_AXIS_TOL = 1e-9  # axes equal to this are one axis (an indexed operation)


def operation_class(axes: np.ndarray, j_tol: float) -> str:
    """'3-axis' (every axis +z), 'indexed' (one other fixed axis: a 3+2 setup), '4-axis-Y'
    (axes in the XZ plane, turning: a rotary table about Y) or 'multi-axis'."""
    if len(axes) == 0 or np.abs(axes - [0.0, 0.0, 1.0]).max() <= _AXIS_TOL:
        return "3-axis"
    if np.abs(axes - axes[0]).max() <= _AXIS_TOL:
        return "indexed"
    return "4-axis-Y" if np.abs(axes[:, 1]).max() <= j_tol else "multi-axis"


def check_job(apt_path, part_path=None, options: CheckOptions = _DEFAULTS) -> ResultsDocument:
    """Check a job: `apt_path` the CL file; `part_path` the part (default: the file beside the
    job with the same stem); `options` how (`CheckOptions`: the cutter, the machine, the
    config, planning, the stock, the machine check, the G-code to post and the policy on
    findings). Returns the results document (`summary.status` is the one answer)."""
    t0 = time.perf_counter()
    with step("read the CL file"):
        toolpath = read_cl(Path(apt_path), require_cutter=options.cutter is None)
    return check_toolpath(toolpath, part_path, options, started=t0)


def _against_stock_only(toolpath, options: CheckOptions, t0: float) -> written.Checked:
    """The program as written against the stock and the fixtures alone (no part): the CAM's
    own motion, nothing planned, nothing posted."""
    apt_path = Path(toolpath.path)
    stock = options.stock or StockRequest()
    if options.to_post:
        raise PathcheckError("a check without a part does not post: the corrected program needs "
                             "the part (give --part, or drop -o)", code="usage")
    if stock.deviation_out is not None:
        raise PathcheckError("--deviation-out compares the machined part with the part: "
                             "expected a part (give --part)", code="usage")
    cfg = job_config(options.config)
    m = toolpath.motion_arrays(arc_chord_tol=cfg.check.arc_chord_tolerance)
    input_limits.refuse_beyond(len(m), input_limits.MAX_CHECK_POSES, "poses to check",
                               "MAX_CHECK_POSES", path=apt_path)
    if len(m) == 0:
        raise PathcheckError("no motion: expected GOTO records", path=apt_path, code="parse")
    ops = np.unique(m.op)
    cutters = operation_cutters(toolpath, ops, options.cutter, apt_path, options.cutter_units)
    tol = operation_tolerances(toolpath, cfg.check.depth_tolerance, 0.0,
                               cfg.check.arc_chord_tolerance)
    classes = {int(o): operation_class(m.axis[m.op == o], cfg.four_axis.axis_j_tolerance)
               for o in ops}
    job = _Job(toolpath, m, None, None, None, cfg, apt_path)
    mach = machine_for_toolpath(toolpath, options.machine)
    job.motion = _machine_motion(mach, {o for o, c in classes.items() if c == "multi-axis"}, cfg)
    motion = written.programmed_motion(job, classes, mach)
    checked = check_stock(job, motion, cutters, tol, stock, None)
    doc = stock_document(job, motion, checked, cutters, classes, tol, mach, t0)
    if options.machine_clearance is not None:
        add_to_document(doc, machine_section(job, motion, cutters, mach, stock, None,
                                             options.machine_clearance))
        doc.summary.time_s = time.perf_counter() - t0
    doc.job.stated_stock = _stated(toolpath, None)
    program = written.Program(m.tip, m.axis, written.cam_b(job), None, None,
                              {o: "as-programmed" for o in classes}, stock=checked)
    counts = {v: int(getattr(doc.summary.counts, v)) for v in verdict.FINDINGS}
    return written.Checked(doc, job, program, mach, cutters, counts, t0)


def _stated(toolpath, part_box: np.ndarray | None) -> str | None:
    """The stock the CL file states, placed against `part_box (2, 3)` (or the origin without a
    part) as `--stock cl` places it: one sentence (`checker.stock.stated.place`), or None."""
    from checker.stock.stated import place, stated_stock

    stated = stated_stock(toolpath)
    return None if stated is None else place(stated, part_box)[1]


def _machine_motion(mach, ops: set[int], cfg: Config):
    """Multi-axis operations `ops` moved as machine `mach` moves them (joints linear), when it
    has two rotary axes; else None: they move in the part frame (tip straight, axis turning in
    its plane), as on no particular machine."""
    if not ops or len(mach.rotary_axes) < 2:
        return None
    tol = float(np.degrees(np.arcsin(min(cfg.four_axis.axis_j_tolerance, 1.0)))) + 1e-9
    return MachineMotion(Chain(mach), bool(mach.tcp.enabled), tol, frozenset(ops))


def _flat_bottomed(toolpath, cutters: dict, ops: list[int], apt_path: Path) -> None:
    """The contact-order strategy positions flat-end and bull-nose cutters: a multi-axis
    operation `ops` with another cutter is a usage error naming it."""
    for o in ops:
        c = cutters[o]
        if c.ball_family or not c.flat_bottomed:
            raise PathcheckError(
                f"--strategy contact-order positions flat-end and bull-nose cutters; operation "
                f"{o + 1} ({toolpath.operations[o].name}) has {c.to_apt()} ({c.kind}): use "
                f"--strategy allowable", path=apt_path, code="usage")


@dataclass
class _Job:
    """What the operations share: the motions, the part and its triangles, the config."""

    toolpath: object
    m: object
    part: object
    triangles: object
    index: object
    cfg: Config
    apt_path: Path
    samples: object = None
    motion: object = None  # multi-axis operations on a 5-axis machine (`five_axis.motion`)

    def test_points(self):
        """The part's test points for the allowable-cutter engine (NURBS parts), made once."""
        if self.samples is None:
            self.samples = sample_part(self.part, geometry=self.cfg.geometry)
        return self.samples


def check_toolpath(toolpath, part_path=None, options: CheckOptions = _DEFAULTS, *,
                   started: float | None = None) -> ResultsDocument:
    """`check_job` on a tool path already in memory (read from a CL file, or from a G-code
    program by `pathcheck check-gcode`); `toolpath.path` names the job; `started` when the
    check began (`time.perf_counter`, s; default now). With `options.output`, the checked
    program is posted there under `options.on_findings` (`posting.post_checked`: refuse raises
    `posting.PostRefusedError`)."""
    checked = check_program(toolpath, part_path, options, started=started)
    if options.output is not None:
        post_checked(checked, options.output, options.on_findings)
    return checked.document


def check_program(toolpath, part_path=None, options: CheckOptions = _DEFAULTS, *,
                  started: float | None = None) -> written.Checked:
    """The check of `check_toolpath` without posting: the results document and what is to be
    written (the program, its machine, cutters and finding counts). With `options.output` the
    program is to be posted, so its machine is resolved even when no operation is planned."""
    t0 = time.perf_counter() if started is None else started
    stock, clearance = options.stock, options.machine_clearance
    if part_path is None and (options.stock_asked or clearance is not None) \
            and find_part_beside(Path(toolpath.path)) is None:
        return _against_stock_only(toolpath, options, t0)
    cfg = job_config(options.config)
    apt_path = Path(toolpath.path)
    m = toolpath.motion_arrays(arc_chord_tol=cfg.check.arc_chord_tolerance)
    input_limits.refuse_beyond(len(m), input_limits.MAX_CHECK_POSES, "poses to check",
                               "MAX_CHECK_POSES", path=apt_path)
    if not (~np.asarray(m.rapid, bool)).any():
        raise PathcheckError("no cutting moves: expected GOTO records after FEDRAT, found only "
                             "rapid moves or none", path=apt_path, code="parse")
    ppath = part_file(apt_path, part_path)
    with step("load the part"):
        part = load_part(ppath, geometry=cfg.geometry)
    transform = None
    if options.part_transform is not None:
        R, t = parse_transform(options.part_transform)
        part = transform_part(part, R, t)
        transform = np.column_stack([R, t]).ravel().tolist()
    with step("triangulate the part"):
        tris = part_triangles(part, cfg.check.part_deviation, cfg.geometry)
        index = MeshIndex.build(tris.vertices, tris.triangles)
    job = _Job(toolpath, m, part, tris, index, cfg, apt_path)
    ops = np.unique(m.op)
    cutters = operation_cutters(toolpath, ops, options.cutter, apt_path, options.cutter_units)
    tol = operation_tolerances(toolpath, cfg.check.depth_tolerance, tris.typical,
                               cfg.check.arc_chord_tolerance)
    mach = None
    classes = {int(o): operation_class(m.axis[m.op == o], cfg.four_axis.axis_j_tolerance)
               for o in ops}
    b_range, reorient = options.b_range, options.reorient
    asked = reorient or b_range is not None
    for o, cls in classes.items():
        if cls == "multi-axis" and b_range is not None and not reorient:
            rows = np.flatnonzero(m.op == o)  # a B search for a path that is not 4-axis
            check_four_axis(m.axis[rows], m.line[rows], str(apt_path),
                            cfg.four_axis.axis_j_tolerance)
    planned = {o for o, cls in classes.items()
               if cls == "4-axis-Y" or (cls == "3-axis" and asked)}
    multi = {o for o, cls in classes.items() if cls == "multi-axis"}
    if planned or multi or options.to_post or clearance is not None:
        mach = machine_for_toolpath(toolpath, options.machine)
        job.motion = _machine_motion(mach, multi, cfg)
    reoriented = multi if reorient else set()
    if options.strategy == "contact-order":
        _flat_bottomed(toolpath, cutters, sorted(reoriented), apt_path)
    with step("plan and check the program"):
        program = written.plan_program(job, cutters, classes, planned, tol, b_range, mach,
                                       reoriented, options.strategy)
    part_box = np.array([tris.vertices.min(axis=0), tris.vertices.max(axis=0)])
    if options.stock_asked:
        program.stock = check_stock(job, program.written.motion, cutters, tol, stock, part_box)
    with step("advice at the cutting poses"):
        doc = build_document(job, program, cutters, classes, tol, ppath, transform, mach, t0)
    if clearance is not None:
        add_to_document(doc, machine_section(job, program.written.motion, cutters, mach, stock,
                                             part_box, clearance))
    doc.summary.time_s = time.perf_counter() - t0
    doc.job.stated_stock = _stated(toolpath, part_box)
    counts = written.written_counts(doc.summary.counts, program)
    return written.Checked(doc, job, program, mach, cutters, counts, t0)
