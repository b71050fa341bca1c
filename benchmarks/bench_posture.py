"""Orientation along a 5-axis path on `samples/impeller/passage.apt` (issue #20): the planner of
`pathcheck --reorient` (least-turn shortest path, then the MB-spline fairing of Hwang et al. 2011)
against the greedy smoothing of Jun, Lee and Cha (2002) on the same feasible sets (the job's own:
real tool, machine reach, `[five_axis]` config), each posture's axes turned into the machine's
rotary words as the post chooses them (`Chain.words_for_axes`); per planner the total rotary motion
(degrees), the peak angular velocity (deg/mm) and acceleration (deg/mm²) over the CC path, and
whether every pose is feasible by the judge. Then the feasible sets' rate (CC points/s,
`bench_feasible.rate`) with the job's grid and the whole `--reorient` job's time. Run: `python -m
benchmarks.bench_posture`."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
JOB = ROOT / "samples" / "impeller" / "passage.apt"


def compare(checked) -> list[tuple[str, object, bool]]:
    """(planner, `PostureMetrics` of its rotary words, all poses feasible) for the CAM, the
    shortest path, shortest path + MB-spline and the greedy smoothing of Jun, Lee and Cha (2002),
    on the first re-oriented operation of a `check_program` result (`reorient=True`)."""
    from checker.five_axis.posture import greedy_smoothing
    from checker.five_axis.reorient import candidates, rotary_metrics

    plan = next(iter(checked.program.fives.values()))
    chain = checked.job.motion.chain
    greedy = greedy_smoothing(candidates(plan.region, plan.frames, plan.cam_axis,
                                         plan.cam_feasible, with_cam=False), plan.cam_axis)
    every = np.arange(len(plan.rows))
    out = []
    for name, axes in (("CAM (hub normal)", plan.cam_axis),
                       ("shortest path", plan.planned.axis),
                       ("shortest path + MB-spline (written)", plan.chosen.axis),
                       ("greedy smoothing (Jun, Lee and Cha)", greedy.axis)):
        out.append((name, rotary_metrics(chain, plan, axes),
                    bool(plan.feasible_at(every, axes).all())))
    return out


def main() -> None:
    from benchmarks.bench_feasible import rate
    from checker.apt import read_cl
    from checker.check import check_program
    from checker.check.options import CheckOptions
    from checker.five_axis.poses import PoseJudge
    from checker.five_axis.reorient import machine_reach

    toolpath = read_cl(JOB)
    options = CheckOptions(reorient=True)
    check_program(toolpath, options=options)  # warm-up: compiled kernels, caches
    t = time.perf_counter()
    checked = check_program(toolpath, options=options)
    job_s = time.perf_counter() - t
    plan = next(iter(checked.program.fives.values()))
    print(f"{'planner':38} {'rotary motion':>13} {'peak deg/mm':>11} {'peak deg/mm2':>12} "
          f"{'feasible':>8}")
    for name, m, ok in compare(checked):
        print(f"{name:38} {m.total_motion_deg:13.1f} {m.peak_velocity_deg_per_mm:11.2f} "
              f"{m.peak_acceleration_deg_per_mm2:12.3f} {'all' if ok else 'not all':>8}")
    job, fa = checked.job, checked.job.cfg.five_axis
    judge = PoseJudge(job.index, checked.cutters[0], float(
        checked.document.operations[0].tolerance), job.triangles.deviation)
    lim = (math.radians(fa.lead_limit_deg), math.radians(fa.tilt_limit_deg))
    reach = machine_reach(job.motion.chain, cone=fa.singular_cone_deg)
    cc, n, f = plan.contacts.cc, plan.contacts.normal, plan.frames.f
    reg, per_s = rate(judge, cc, n, f, lead_range=(-lim[0], lim[0]),
                      tilt_range=(-lim[1], lim[1]), step=math.radians(fa.grid_step_deg),
                      tolerance=math.radians(fa.boundary_tolerance_deg), machine=reach)
    nodes = reg.mask.shape[1] * reg.mask.shape[2]
    print(f"feasible sets: {len(cc)} CC points, {nodes} grid poses each "
          f"({fa.grid_step_deg:g} deg), boundary to {fa.boundary_tolerance_deg:g} deg: "
          f"{per_s:.1f} CC points/s; {reg.mask.mean():.1%} of the nodes feasible, "
          f"{len(reg.crossing)} crossings")
    def found(c) -> int:
        return sum(getattr(c, v) for v in ("gouge", "interference", "holder", "crash"))

    summary = checked.document.summary
    print(f"whole job with --reorient (no G-code): {job_s:.1f} s; findings at the CAM's axes "
          f"{found(summary.counts_cam)}, written {found(summary.counts)}")


if __name__ == "__main__":
    main()
