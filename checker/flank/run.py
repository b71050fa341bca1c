"""The flank job: the pass of a CL file against a part's design surface, before and
(optionally) after the axis optimisation, as a `FlankDocument`. Part frame, mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.cutter import Cutter
from checker.errors import PathcheckError
from checker.flank.envelope import profile
from checker.flank.error import envelope_error, foot_points
from checker.flank.error_document import FlankDocument, Optimisation, flank_result
from checker.flank.optimise import optimise_axis
from checker.flank.path import flank_pass
from checker.flank.spline_motion import ToolMotion
from checker.part import Part
from checker.toolpath import ToolPath

PER_MOVE = 4  # path samples per move (the poses and three between)


@dataclass(frozen=True)
class FlankRun:
    """The document and, when optimised, the improved poses (tips, axes (K, 3)) at file
    `lines` (K,)."""

    document: FlankDocument
    lines: np.ndarray
    tips: np.ndarray | None = None
    axes: np.ndarray | None = None


def heights(cutter: Cutter, count: int) -> np.ndarray:
    """(count,) heights above the tip (mm) on the cutter's side: from just above the corner
    centre up to H, else the flute length, else four diameters."""
    top = cutter.H or cutter.flute_length or 4.0 * cutter.d
    lo = cutter.f + 1e-3 * max(cutter.d, 1.0)
    if top <= lo:
        raise PathcheckError(f"the cutter's side ends at {top:g} mm, below its corner ({lo:g} mm)")
    return np.linspace(lo, top, count)


def design_surface(part: Part, tips: np.ndarray, axes: np.ndarray, cutter: Cutter,
                   z: np.ndarray) -> int:
    """The index of the part's surface the pass flanks: the one whose distance to the axis at
    mid-height is nearest the cutter's radius there, on average over the poses."""
    zm = float(np.median(z))
    rho, _ = profile(cutter, np.array([zm]))
    gaps = [np.mean(np.abs(foot_points(s, tips + zm * axes)[2] - rho[0])) for s in part.surfaces]
    return int(np.argmin(gaps))


def flank_job(toolpath: ToolPath, part: Part, cutter: Cutter | None, part_name: str, *,
              tolerance: float, surface: int | None = None, count: int = 25,
              optimise: bool = False, max_evaluations: int = 20) -> FlankRun:
    """The flank pass of `toolpath` against the part (its surface index `surface`, else the
    nearest), errors at `count` heights; status 'findings' when the final path's overcut or
    undercut exceeds `tolerance` mm. `cutter` None: the CUTTER of the pass's operation."""
    m = toolpath.motion_arrays()
    rows = flank_pass(m, toolpath.path)
    cutter = cutter or toolpath.operations[int(m.op[rows[0]])].cutter
    if cutter is None:
        raise PathcheckError("no CUTTER for the flank pass: give --cutter", path=toolpath.path)
    tips, axes, lines = m.tip[rows], m.axis[rows], m.line[rows]
    z = heights(cutter, count)
    if surface is not None and not 0 <= surface < len(part.surfaces):
        raise PathcheckError(f"--surface: expected 0 to {len(part.surfaces) - 1}, found {surface}")
    index = surface if surface is not None else design_surface(part, tips, axes, cutter, z)
    design = part.surfaces[index]
    before = envelope_error(cutter, ToolMotion.through(tips, axes, float(z.max())), design, z,
                            PER_MOVE)
    after = opt = None
    new_tips = new_axes = None
    if optimise:
        o = optimise_axis(cutter, design, tips, axes, z, PER_MOVE,
                          max_evaluations=max_evaluations)
        after, new_tips, new_axes = o.after, o.tips, o.axes
        opt = Optimisation(evaluations=o.evaluations, message=o.message, written=None)
    final = before if after is None else after
    e = final.error[np.isfinite(final.error)]
    bad = e.size and max(e.max(), -e.min()) > tolerance
    doc = FlankDocument(
        job=toolpath.path, part=part_name, surface=index, cutter=cutter.to_apt(),
        heights=[float(z[0]), float(z[-1]), float(len(z))], tolerance=tolerance,
        status="findings" if bad else "ok",
        before=flank_result(before, design, lines),
        after=None if after is None else flank_result(after, design, lines),
        optimisation=opt)
    return FlankRun(doc, lines, new_tips, new_axes)
