"""A summary document of a G-code program read back into the part frame (what `pathcheck
check-gcode` reports): counts, units, tools, B range, part-frame bounding box, feeds."""

from __future__ import annotations

import numpy as np

from postproc.machine import Machine
from postproc.reader import CYCLE, HOME, MACHINE_FRAME, GcodeMoves
from postproc.replay import PartMotions


def _range(values: np.ndarray) -> list[float] | None:
    finite = values[np.isfinite(values)]
    return [round(float(finite.min()), 4), round(float(finite.max()), 4)] if finite.size else None


def describe_program(moves: GcodeMoves, motions: PartMotions, machine: Machine) -> dict:
    """JSON-ready summary: ``program``, ``dialect``, ``units``, ``machine``, ``blocks {motion,
    rapid, feed, arc, cycle, home, machine_frame}``, ``points {total, known}`` (arcs in chords),
    ``tools`` (loaded by M6), ``b_deg [min, max]`` (part rotation), ``bbox_mm`` (part frame,
    known points), ``feed_mm_min [min, max]`` (tip speed relative to the part), ``other {CODE:
    count}``."""
    known = motions.known
    tips = motions.tip[known]
    return {
        "program": moves.path,
        "dialect": moves.dialect,
        "units": moves.units,
        "machine": machine.name,
        "blocks": {
            "motion": len(moves),
            "rapid": int((moves.motion == 0).sum()),
            "feed": int((moves.motion == 1).sum()),
            "arc": int(np.isin(moves.motion, (2, 3)).sum()),
            "cycle": int((moves.kind == CYCLE).sum()),
            "home": int((moves.kind == HOME).sum()),
            "machine_frame": int((moves.kind == MACHINE_FRAME).sum()),
        },
        "points": {"total": len(motions), "known": int(known.sum())},
        "tools": sorted({int(t) for t in np.unique(moves.tool) if t > 0}),
        "b_deg": _range(motions.b_deg[known]),
        "bbox_mm": None if not len(tips) else [_range(tips[:, k]) for k in range(3)],
        "feed_mm_min": _range(motions.feed),
        "other": dict(sorted(moves.other.items())),
    }


def format_program_summary(doc: dict) -> str:
    """The summary as a few lines of text."""
    b = doc["blocks"]
    lines = [
        f"{doc['program']}: {doc['dialect']} G-code, {doc['units']}, machine {doc['machine']}",
        f"  blocks: {b['motion']} moves ({b['rapid']} rapid, {b['feed']} feed, {b['arc']} arc, "
        f"{b['cycle']} canned-cycle, {b['home']} home, {b['machine_frame']} machine-frame)",
        f"  points: {doc['points']['known']} of {doc['points']['total']} known in the part frame",
        f"  tools: {', '.join(map(str, doc['tools'])) or '-'}; B: {doc['b_deg']} deg; "
        f"feed: {doc['feed_mm_min']} mm/min",
    ]
    if doc["bbox_mm"]:
        x, y, z = doc["bbox_mm"]
        lines.append(f"  part-frame box: X {x} Y {y} Z {z} mm")
    if doc["other"]:
        lines.append("  other codes: " + ", ".join(f"{k} x{v}" for k, v in doc["other"].items()))
    return "\n".join(lines)
