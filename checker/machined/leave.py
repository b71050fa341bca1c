"""The stock each operation leaves on the part on purpose: the CL file's part-surface thickness
(`THICK/s`, s > 0, written before the operation's first motion) or `--leave MM`, the larger.
mm (docs/MATH.md §15.3)."""

from __future__ import annotations

import numpy as np

from checker.toolpath import ToolPath
from checker.units import mm_per_unit


def operation_leave(toolpath: ToolPath, leave: float = 0.0) -> np.ndarray:
    """(K,) mm per operation of `toolpath`: max(its THICK (0 when none or negative), leave)."""
    scale = mm_per_unit(toolpath.units)
    words = [(rec.line, float(nums[0]) * scale) for rec in toolpath.records
             if rec.word == "THICK"
             for nums in [[a for a in rec.args if not isinstance(a, str)]] if nums]
    lines = toolpath.motions.line
    out = []
    for op in toolpath.operations:
        first = lines[op.first_motion] if op.first_motion < len(lines) else np.inf
        thick = 0.0
        for line, value in words:
            if line >= first:
                break
            thick = value
        out.append(max(thick, 0.0, float(leave)))
    return np.asarray(out, dtype=float)
