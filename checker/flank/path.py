"""The flank pass of a CL file and the file with the pass's poses replaced: the pass is the
longest run of consecutive cutting moves that move the tool more across its axis than along
it, or turn it in place (a plunge or retract, a rapid or a canned cycle ends it). Part frame,
mm."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from checker.apt.write import apt_text
from checker.errors import PathcheckError
from checker.toolpath import MotionArrays, Record, ToolPath
from checker.units import MM_PER_INCH

ACROSS = 5e-3  # mm of tip motion across the axis that make a flank move (above CL rounding)
TURN = 1e-4  # rad of axis turn that make a flank move


def flank_pass(m: MotionArrays, path: str) -> np.ndarray:
    """Row indices (K,) of the flank pass: the longest run of consecutive non-rapid,
    non-cycle motions whose steps move the tip more across the axis than along it (and by
    more than ACROSS), or turn the axis by more than TURN with the tip within ACROSS."""
    cut = ~m.rapid & ~m.cycle
    d = np.diff(m.tip, axis=0)
    along = np.einsum("ij,ij->i", d, m.axis[:-1])
    across = np.linalg.norm(d - along[:, None] * m.axis[:-1], axis=1)
    turn = np.linalg.norm(np.diff(m.axis, axis=0), axis=1)
    sideways = (across > ACROSS) & (across >= np.abs(along))
    in_place = (turn > TURN) & (np.linalg.norm(d, axis=1) <= ACROSS)
    step = cut[:-1] & cut[1:] & (sideways | in_place)
    best, start, run = (0, 0), 0, 0
    for i, ok in enumerate(step):  # one pass over the moves: the longest run of True
        run = run + 1 if ok else 0
        start = i - run + 1 if ok else start
        if run > best[1] - best[0]:
            best = (start, i + 1)
    if best[1] - best[0] < 2:
        raise PathcheckError("expected a flank pass of at least three cutting poses "
                             "moving sideways to the tool axis, found none", path=path)
    return np.arange(best[0], best[1] + 1)


def replaced_apt(toolpath: ToolPath, lines: np.ndarray, tips: np.ndarray,
                 axes: np.ndarray) -> str:
    """The CL file's text with the GOTOs at file `lines` (K,) moved to `tips`, `axes` (K, 3),
    mm in the part frame, written in the file's units."""
    if any(f.applied for f in toolpath.frames):
        raise PathcheckError("cannot write the improved path: the file "
                             "uses a coordinate frame (CSYS/MSYS)", path=toolpath.path)
    scale = 1.0 / MM_PER_INCH if toolpath.units == "inch" else 1.0
    at = {int(line): k for k, line in enumerate(lines)}
    records: list[Record] = []
    for rec in toolpath.records:
        k = at.get(rec.line) if rec.word == "GOTO" else None
        if k is None:
            records.append(rec)
            continue
        if len(rec.args) < 6:
            raise PathcheckError("expected GOTO/x,y,z,i,j,k "
                                 "(MULTAX) to write a tool axis", path=toolpath.path,
                                 line=rec.line)
        vals = tuple(float(round(v, 6)) for v in (*(tips[k] * scale), *axes[k]))
        records.append(replace(rec, args=vals + tuple(rec.args[6:])))
    return apt_text(replace(toolpath, records=records))
