"""How much the rotary axes move: the written program's against the CAM's, for the operations
that were planned. 4-axis: the sum of |dB| along every motion row with a B (operation changes
included), and the greedy smoothing's inside the planned operations (Jun, Lee and Cha 2002);
re-oriented multi-axis operations: the total motion of the machine's rotary words along the
contact points at the chosen and at the CAM's axes (`five_axis.reorient.rotary_metrics`, through the
machine's chain). Degrees."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from checker.check.context import JobContext
from checker.check.program import Program


@dataclass(frozen=True)
class FourAxisRotation:
    """The table's motion (degrees): `written` along the written program, `cam` along the
    CAM's, `greedy` the greedy smoothing's inside the planned operations (None unless the config
    asks for it, `four_axis.greedy_baseline`); `infeasible_points`
    the planned contacts with no feasible B."""

    written: float
    greedy: float | None
    cam: float
    infeasible_points: int


@dataclass(frozen=True)
class RotaryMotion:
    """`four_axis` (None when no 4-axis operation was planned) and, per re-oriented multi-axis
    operation, the rotary words' total motion (degrees) at the chosen axes and at the CAM's
    (`five_axis`, None each without a 5-axis chain)."""

    four_axis: FourAxisRotation | None = None
    five_axis: dict[int, tuple[float | None, float | None]] = field(default_factory=dict)


def reoriented_fives(program: Program) -> dict:
    """The multi-axis plans whose program is written (handling re-oriented)."""
    return {o: p for o, p in program.fives.items() if program.handling[o] == "re-oriented"}


def rotary_motion(job: JobContext, program: Program) -> RotaryMotion:
    """The rotary motion of the written program and of the CAM's (see the module
    docstring)."""
    from checker.four_axis.orientation import total_rotation

    four = None
    plans = [p for o, p in program.plans.items() if program.handling[o] != "as-programmed"]
    if plans:
        b_cam = job.cam_b()
        four = FourAxisRotation(
            written=total_rotation(program.b[np.isfinite(program.b)]),
            greedy=None if any(p.orientations.greedy is None for p in plans) else
            sum(float(p.orientations.greedy.total_rotation) for p in plans),
            cam=total_rotation(b_cam[np.isfinite(b_cam)]),
            infeasible_points=sum(int((~p.orientations.chosen.feasible).sum())
                                  for p in plans))
    chain = None if job.motion is None else job.motion.chain
    five = {o: _words_motion(p, chain) for o, p in reoriented_fives(program).items()}
    return RotaryMotion(four, five)


def _words_motion(p, chain) -> tuple[float | None, float | None]:
    """Total motion of the machine's rotary words (degrees) along a multi-axis plan's contact
    points at its chosen axes and at the CAM's (None without a 5-axis chain)."""
    from checker.five_axis.reorient import rotary_metrics

    if chain is None:
        return None, None
    return (rotary_metrics(chain, p, p.chosen.axis).total_motion_deg,
            rotary_metrics(chain, p, p.cam_axis).total_motion_deg)
