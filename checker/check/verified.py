"""The real tool along one version of a job's motions, and its verdicts: the poses and moves as the
machine makes them (`checker.moves`; multi-axis operations on a 5-axis machine with its joints
linear, `checker.five_axis.machine_motion`), the depth of the cutter, shank and holder at every pose
and along every move (`checker.verify`), and the one verdict rule (`checker.verdict`) with each
pose's tolerance: the operation's plus the part's deviation near the deepest point. Part frame, mm,
degrees (MATH.md §8)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from checker import verdict as vd
from checker.errors import PathcheckError
from checker.five_axis.machine_motion import machine_path
from checker.mesh.tool import tool_pieces
from checker.moves import RAPID, START, Moves, machine_moves
from checker.verify import Depths, MoveDepths, ProgramMotion, tool_depths

if TYPE_CHECKING:
    from checker.check.context import JobContext


@dataclass
class Verified:
    """The real tool along one version of the motions: the poses and moves (`moves`), the
    depths at every pose and along every move (`along`, per move end), their verdicts and the
    tolerance of each pose and move (the operation's plus the part's deviation near the deepest
    point)."""

    moves: Moves
    poses: Depths
    along: MoveDepths
    pose_verdict: np.ndarray
    move_verdict: np.ndarray
    tolerance: np.ndarray
    move_tolerance: np.ndarray
    motion: ProgramMotion | None = None

    def findings(self, poses: np.ndarray) -> int:
        """Findings at the poses `poses` and along the moves that reach them."""
        at_move = np.isin(self.along.end, poses)
        return int(vd.is_finding(self.pose_verdict[poses]).sum()
                   + vd.is_finding(self.move_verdict[at_move]).sum())


def program_motion(job: JobContext, tip: np.ndarray, axis: np.ndarray,
                   b: np.ndarray) -> ProgramMotion:
    """The poses and moves of the motions (tips, axes, table angles `b` per motion row, nan:
    none) as the machine makes them (the table turning about the machine's table centre);
    multi-axis operations on a 5-axis machine run its joints linearly."""
    moves = machine_moves(replace(job.m, tip=tip, axis=axis))
    five = job.motion
    path = None if five is None else machine_path(five, axis, job.m.line, str(job.apt_path),
                                                  moves.row, moves.tip)
    return ProgramMotion(moves, job.m.op[moves.row], b[moves.row], job.table_center(), path,
                         frozenset() if five is None else frozenset(five.ops))


def verify_motions(job: JobContext, tip: np.ndarray, axis: np.ndarray,
                   b: np.ndarray) -> Verified:
    """The real tool (each operation's cutter with its shank and holder) at every pose of the
    motions (tips, axes per motion row) and along every move, against the part's triangles;
    rows with a table angle `b` (not nan) move linearly in machine X Y Z B."""
    cfg = job.cfg
    motion = program_motion(job, tip, axis, b)
    moves = motion.moves
    tolerance = job.tolerance.value[motion.op_of]
    box = job.part_box + [[-cfg.check.reach], [cfg.check.reach]]
    pieces = {o: tool_pieces(job.cutters[o], with_holder=True) for o in np.unique(motion.op_of)}
    poses, along = tool_depths(job.index, box, motion, pieces, tolerance, cfg.check.reach)
    near = _near(job, moves, poses.height)
    rapid_pose = (moves.kind == RAPID) | ((moves.kind == START) & job.m.rapid[moves.row])
    local = _local_deviation(job, poses.triangle)
    pose_verdict = vd.decide(poses.depth, poses.piece, rapid_pose, near, tolerance + local)
    move_near = _near(job, moves, along.depths.height, along.end)
    move_tol = tolerance[along.end] + _local_deviation(job, along.depths.triangle)
    # the depth is continuous: a move whose end pose penetrates penetrates next to it too, at
    # least within the tolerance where the poses checked along it found nothing deeper
    touching = np.maximum(poses.depth[along.end - 1], poses.depth[along.end])
    move_verdict = vd.decide(np.maximum(along.depths.depth, np.minimum(touching, move_tol)),
                             along.depths.piece,
                             (moves.kind[along.end] == RAPID) & ~moves.retract[along.end],
                             move_near, move_tol)
    return Verified(moves, poses, along, pose_verdict, move_verdict, tolerance + local, move_tol,
                    motion)


def _local_deviation(job: JobContext, triangle: np.ndarray) -> np.ndarray:
    """The deviation of the part's triangles from its surfaces at the deepest triangles
    (0 where there is none)."""
    dev = job.triangles.deviation
    return np.where(triangle >= 0, dev[np.maximum(triangle, 0)], 0.0)


def _near(job: JobContext, moves: Moves, height: np.ndarray,
          at: np.ndarray | None = None) -> np.ndarray:
    """Whether the deepest point is on the cutting end of the cutter (within
    `check.gouge_neighbourhood` radii of the tip): where a penetration is a gouge."""
    at = np.arange(len(moves)) if at is None else at
    op_of = job.m.op[moves.row[at]]
    reach = np.array([job.cfg.check.gouge_neighbourhood * 0.5 * job.cutters[int(o)].d
                      for o in op_of]) if len(at) else np.zeros(0)
    return np.nan_to_num(height, nan=np.inf) <= reach


def check_frames(job: JobContext, verified: Verified) -> None:
    """A part in another frame than its path: most cutting poses deep inside it. The depth
    into the part's surface saturates at the cutter's inradius when a pose is buried (the
    deepest point of the surface inside the cutter is at most a radius from its side), so deep
    means more than half the cutter radius. One line with the boxes and their offset, instead
    of a finding per pose."""
    mv = verified.moves
    cutting = np.flatnonzero((mv.kind != RAPID) & ~mv.hole & ~job.m.rapid[mv.row])
    if len(cutting) < 10:
        return
    radius = np.array([0.5 * job.cutters[int(o)].d for o in job.m.op[mv.row[cutting]]])
    deep = verified.poses.depth[cutting] > 0.5 * radius
    share = float(deep.mean())
    if share < job.cfg.check.misaligned_fraction:
        return
    path_box = np.array([mv.tip[cutting].min(axis=0), mv.tip[cutting].max(axis=0)])
    part_box = job.part_box
    off = path_box.mean(axis=0) - part_box.mean(axis=0)
    fmt = lambda v: "(" + ", ".join(f"{x:.3f}" for x in v) + ")"  # noqa: E731
    raise PathcheckError(
        f"part and path do not line up: {share:.0%} of the cutting poses are deeper in the part "
        f"than half the cutter radius; path box {fmt(path_box[0])}..{fmt(path_box[1])}, part box "
        f"{fmt(part_box[0])}..{fmt(part_box[1])}, centres offset by {fmt(off)} mm: give "
        f"--part-transform with the part's placement in the CL frame",
        path=job.apt_path, code="frames")


def pose_of_rows(moves: Moves, rows: np.ndarray) -> np.ndarray:
    """The pose of each motion row `rows` (the first pose it makes)."""
    first = np.searchsorted(moves.row, rows)
    return np.minimum(first, len(moves.row) - 1)
