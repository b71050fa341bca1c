"""The job context: what every stage of the check shares, resolved once from the caller's
inputs (`checker.check.inputs`) and options (`CheckOptions`): the tool path and its motions,
the config, the part with its triangles and their search index, every operation's cutter,
tolerance and axis class, which operations are planned or re-oriented, and the machine and
how it moves multi-axis operations. Part frame, mm, degrees."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from checker import input_limits
from checker.b_axis import b_for_axis, check_four_axis
from checker.check.inputs import job_config, operation_cutters, part_file
from checker.check.options import CheckOptions
from checker.config import Config
from checker.cutter import Cutter
from checker.errors import PathcheckError
from checker.five_axis.machine_motion import MachineMotion
from checker.geometry import load_part
from checker.geometry.sampling import TestPoints, sample_part
from checker.geometry.tessellate import PartTriangles, part_triangles
from checker.geometry.transform import parse_transform, transform_part
from checker.mesh.bvh import MeshIndex
from checker.part import Part
from checker.postproc.kinematics import Chain
from checker.postproc.machine import Machine
from checker.postproc.post import machine_for_toolpath
from checker.progress import step
from checker.tolerance import Tolerances, operation_tolerances
from checker.toolpath import MotionArrays, ToolPath

_AXIS_TOL = 1e-9  # axes equal to this are one axis (an indexed operation)


@dataclass(frozen=True)
class JobContext:
    """A job as the stages of the check see it.

    - `toolpath` the CL file read (`apt_path` names it); `m` its motions, one row per motion
      (tips, axes, rapid, feed, line, operation: `MotionArrays`, mm, part frame).
    - `cfg` the config; `options` what the caller asked (`CheckOptions`).
    - `part` the part (None: a check against the stock, the fixtures or the machine alone),
      `part_path` its file, `part_transform` its placement (3 x 4 row-major, None: as read);
      `triangles` the part within `cfg.check.part_deviation` (`geometry.tessellate`), `index`
      their search index (`mesh.bvh`), `part_box (2, 3)` their box.
    - per operation index: `cutters` the real cutter, `tolerance` the tolerance in effect
      (`checker.tolerance`), `classes` the axis class (`operation_class`).
    - `planned` the operations whose table angle B is planned (4-axis, or 3-axis when asked),
      `reoriented` the multi-axis ones re-oriented (`options.strategy`).
    - `machine` the machine (None when neither planning, posting nor the machine check needs
      one), `motion` how it moves the multi-axis operations (joints linear; None: in the part
      frame)."""

    toolpath: ToolPath
    m: MotionArrays
    cfg: Config
    options: CheckOptions
    apt_path: Path
    cutters: dict[int, Cutter]
    tolerance: Tolerances
    classes: dict[int, str]
    part: Part | None = None
    part_path: Path | None = None
    part_transform: list[float] | None = None
    triangles: PartTriangles | None = None
    index: MeshIndex | None = None
    part_box: np.ndarray | None = None
    planned: frozenset[int] = frozenset()
    reoriented: frozenset[int] = frozenset()
    machine: Machine | None = None
    motion: MachineMotion | None = None

    @cached_property
    def samples(self) -> TestPoints:
        """The part's test points for the allowable-cutter engine (NURBS parts), made once."""
        return sample_part(self.part, geometry=self.cfg.geometry)

    def test_points(self) -> TestPoints:
        """`samples` (the name the planners ask by)."""
        return self.samples

    def cutting_rows(self, rows: np.ndarray) -> np.ndarray:
        """Of the motion rows `rows`, the cutting ones: feed moves that are not canned-cycle
        holes (the advice and the planning are for them)."""
        return rows[~self.m.rapid[rows] & ~self.m.cycle[rows]]

    def cam_b(self) -> np.ndarray:
        """The CAM's table angle B per motion row (degrees; nan where the axis is not in the XZ
        plane)."""
        j_ok = np.abs(self.m.axis[:, 1]) <= self.cfg.four_axis.axis_j_tolerance
        return np.where(j_ok, b_for_axis(self.m.axis), np.nan)

    def table_center(self) -> np.ndarray:
        """The point (3,) mm the table turns about (the machine's; the origin without one)."""
        if self.machine is None:
            return np.zeros(3)
        return np.asarray(self.machine.kinematics.table_center, float)


def operation_class(axes: np.ndarray, j_tol: float) -> str:
    """'3-axis' (every axis +z), 'indexed' (one other fixed axis: a 3+2 setup), '4-axis-Y'
    (axes in the XZ plane, turning: a rotary table about Y) or 'multi-axis'."""
    if len(axes) == 0 or np.abs(axes - [0.0, 0.0, 1.0]).max() <= _AXIS_TOL:
        return "3-axis"
    if np.abs(axes - axes[0]).max() <= _AXIS_TOL:
        return "indexed"
    return "4-axis-Y" if np.abs(axes[:, 1]).max() <= j_tol else "multi-axis"


def machine_motion(mach: Machine, ops: set[int], cfg: Config) -> MachineMotion | None:
    """Multi-axis operations `ops` moved as machine `mach` moves them (joints linear), when it
    has two rotary axes; else None: they move in the part frame (tip straight, axis turning in
    its plane), as on no particular machine."""
    if not ops or len(mach.rotary_axes) < 2:
        return None
    tol = float(np.degrees(np.arcsin(min(cfg.four_axis.axis_j_tolerance, 1.0)))) + 1e-9
    return MachineMotion(Chain(mach), bool(mach.tcp.enabled), tol, frozenset(ops))


def _motions(toolpath: ToolPath, cfg: Config, apt_path: Path) -> MotionArrays:
    """The motions of `toolpath`, refused beyond `input_limits.MAX_CHECK_POSES` rows."""
    m = toolpath.motion_arrays(arc_chord_tol=cfg.check.arc_chord_tolerance)
    input_limits.refuse_beyond(len(m), input_limits.MAX_CHECK_POSES, "poses to check",
                               "MAX_CHECK_POSES", path=apt_path)
    return m


def _classes(m: MotionArrays, cfg: Config) -> dict[int, str]:
    return {int(o): operation_class(m.axis[m.op == o], cfg.four_axis.axis_j_tolerance)
            for o in np.unique(m.op)}


def _flat_bottomed(toolpath: ToolPath, cutters: dict, ops: list[int], apt_path: Path) -> None:
    """The contact-order strategy positions flat-end and bull-nose cutters: a multi-axis
    operation `ops` with another cutter is a usage error naming it."""
    for o in ops:
        c = cutters[o]
        if c.ball_family or not c.flat_bottomed:
            raise PathcheckError(
                f"--strategy contact-order positions flat-end and bull-nose cutters; operation "
                f"{o + 1} ({toolpath.operations[o].name}) has {c.to_apt()} ({c.kind}): use "
                f"--strategy allowable", path=apt_path, code="usage")


def job_context(toolpath: ToolPath, part_path, options: CheckOptions) -> JobContext:
    """The context of a check against the part: the motions (at least one cutting move), the
    part (`part_path`, else the file beside the job) placed by `options.part_transform`, its
    triangles and index, the operations' cutters, tolerances and classes, what is planned, and
    the machine where planning, posting or the machine check needs one."""
    cfg = job_config(options.config)
    apt_path = Path(toolpath.path)
    m = _motions(toolpath, cfg, apt_path)
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
    cutters = operation_cutters(toolpath, np.unique(m.op), options.cutter, apt_path,
                                options.cutter_units)
    tol = operation_tolerances(toolpath, cfg.check.depth_tolerance, tris.typical,
                               cfg.check.arc_chord_tolerance)
    classes = _classes(m, cfg)
    b_range, reorient = options.b_range, options.reorient
    for o, cls in classes.items():
        if cls == "multi-axis" and b_range is not None and not reorient:
            rows = np.flatnonzero(m.op == o)  # a B search for a path that is not 4-axis
            check_four_axis(m.axis[rows], m.line[rows], str(apt_path),
                            cfg.four_axis.axis_j_tolerance)
    asked = reorient or b_range is not None
    planned = {o for o, cls in classes.items()
               if cls == "4-axis-Y" or (cls == "3-axis" and asked)}
    multi = {o for o, cls in classes.items() if cls == "multi-axis"}
    mach = motion = None
    if planned or multi or options.to_post or options.machine_clearance is not None:
        mach = machine_for_toolpath(toolpath, options.machine)
        motion = machine_motion(mach, multi, cfg)
    reoriented = multi if reorient else set()
    if options.strategy == "contact-order":
        _flat_bottomed(toolpath, cutters, sorted(reoriented), apt_path)
    part_box = np.array([tris.vertices.min(axis=0), tris.vertices.max(axis=0)])
    return JobContext(toolpath, m, cfg, options, apt_path, cutters, tol, classes, part, ppath,
                      transform, tris, index, part_box, frozenset(planned),
                      frozenset(reoriented), mach, motion)


def context_without_part(toolpath: ToolPath, options: CheckOptions) -> JobContext:
    """The context of a check against the stock, the fixtures or the machine alone (no part):
    the motions (at least one), the operations' cutters, tolerances (no part deviation) and
    classes, and the machine; nothing is planned."""
    cfg = job_config(options.config)
    apt_path = Path(toolpath.path)
    m = _motions(toolpath, cfg, apt_path)
    if len(m) == 0:
        raise PathcheckError("no motion: expected GOTO records", path=apt_path, code="parse")
    cutters = operation_cutters(toolpath, np.unique(m.op), options.cutter, apt_path,
                                options.cutter_units)
    tol = operation_tolerances(toolpath, cfg.check.depth_tolerance, 0.0,
                               cfg.check.arc_chord_tolerance)
    classes = _classes(m, cfg)
    mach = machine_for_toolpath(toolpath, options.machine)
    motion = machine_motion(mach, {o for o, c in classes.items() if c == "multi-axis"}, cfg)
    return JobContext(toolpath, m, cfg, options, apt_path, cutters, tol, classes,
                      machine=mach, motion=motion)
