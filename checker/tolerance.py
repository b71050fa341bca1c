"""How deep the real tool may go into the part before a pose is a finding, per operation: the
job's own inside tolerance (APT `INTOL/t`, or `TOLER/t`), plus the stock it is told to cut
below the part (a negative part-surface thickness `THICK/-s`: the CAM meant to go s into the
part), else `check.depth_tolerance` from the config; plus what the geometry adds: the deviation
of the part's triangles from the surface they stand for (a mesh's chordal deviation, near the
deepest point: `checker.check.verified` adds it per pose) and, in an operation that has arcs,
the chord error of the arcs sampled into straight moves. mm."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.toolpath import ToolPath
from checker.units import mm_per_unit

_WORDS = frozenset({"INTOL", "TOLER", "THICK"})


@dataclass(frozen=True)
class Tolerances:
    """Per operation (K,): the tolerance in effect (mm) and where it comes from ("INTOL",
    "config"), the arc chord error included in those that have arcs; the part's typical
    deviation (mm), which is not included (the deviation near each pose's deepest point is)."""

    value: np.ndarray
    source: list[str]
    part_deviation: float
    arc_chord: float


def _number(rec) -> float | None:
    nums = [a for a in rec.args if not isinstance(a, str)]
    return float(nums[0]) if nums else None


def operation_tolerances(toolpath: ToolPath, default: float, part_deviation: float,
                         arc_chord: float) -> Tolerances:
    """The tolerance of every operation of `toolpath` (see the module docstring): the words
    written before an operation's first motion apply to all of it; `arc_chord` is added to the
    operations with an arc."""
    scale = mm_per_unit(toolpath.units)
    words = [(rec.line, rec.word, _number(rec)) for rec in toolpath.records
             if rec.word in _WORDS and _number(rec) is not None]
    lines = toolpath.motions.line
    arcs = toolpath.motions.arc
    values, sources = [], []
    for op in toolpath.operations:
        first = lines[op.first_motion] if op.first_motion < len(lines) else np.inf
        intol, thick = None, 0.0
        for line, word, value in words:
            if line >= first:
                break
            if word == "THICK":
                thick = value * scale
            else:
                intol = abs(value) * scale
        has_arc = bool((arcs[op.first_motion:op.end_motion] >= 0).any())
        values.append((default if intol is None else intol) + max(-thick, 0.0)
                      + (arc_chord if has_arc else 0.0))
        sources.append("config" if intol is None else "INTOL")
    return Tolerances(np.asarray(values, dtype=float), sources, part_deviation, arc_chord)
