"""A summary document of a G-code program read back into the part frame (what `pathcheck
check-gcode` reports): counts, units, tools, the axis ranges (machine X Y Z and rotary
positions), the part-frame bounding box, feeds, and the machine checks (`postproc.checks`)."""

from __future__ import annotations

import numpy as np

from checker.postproc.checks import machine_checks, machine_xyz
from checker.postproc.machine import Machine
from checker.postproc.reader import CYCLE, HOME, MACHINE_FRAME, GcodeMoves
from checker.postproc.replay import PartMotions


def _range(values: np.ndarray) -> list[float] | None:
    finite = values[np.isfinite(values)]
    return [round(float(finite.min()), 4), round(float(finite.max()), 4)] if finite.size else None


def describe_program(moves: GcodeMoves, motions: PartMotions, machine: Machine) -> dict:
    """JSON-ready summary: ``program``, ``dialect``, ``units``, ``machine``, ``kind`` (the
    chain, e.g. ``table-table A/C``), ``blocks`` (blocks read), ``motions {motion, rapid, feed,
    arc, cycle, home, machine_frame, tcp}`` (motion rows), ``points {total, known}`` (arcs in
    chords), ``tools`` (loaded), ``axes {X, Y, Z: [min, max] mm machine coordinates, A/B/C:
    [min, max] deg}``, ``bbox_mm`` (part frame, known points), ``b_deg`` (part rotation about +Y
    of the tool axes, the 4-axis view), ``feed_mm_min [min, max]`` (tip speed relative to the
    part), ``machine_checks`` (findings), ``other {CODE: count}``."""
    known = motions.known
    tips = motions.tip[known]
    xyz = machine_xyz(motions, machine)[known]
    axes = {letter: _range(xyz[:, k]) for k, letter in enumerate("XYZ")}
    joints = motions.joints if motions.joints is not None else np.zeros((len(known), 0))
    for k, name in enumerate(motions.names):
        axes[name] = _range(joints[known, k])
    tcp = moves.tcp if moves.tcp is not None else np.zeros(len(moves), bool)
    return {
        "program": moves.path,
        "dialect": moves.dialect,
        "units": moves.units,
        "machine": machine.name,
        "kind": machine.kind,
        "blocks": moves.blocks,
        "motions": {
            "motion": len(moves),
            "rapid": int((moves.motion == 0).sum()),
            "feed": int((moves.motion == 1).sum()),
            "arc": int(np.isin(moves.motion, (2, 3)).sum()),
            "cycle": int((moves.kind == CYCLE).sum()),
            "home": int((moves.kind == HOME).sum()),
            "machine_frame": int((moves.kind == MACHINE_FRAME).sum()),
            "tcp": int(tcp.sum()),
        },
        "points": {"total": len(motions), "known": int(known.sum())},
        "tools": sorted({int(t) for t in np.unique(moves.tool) if t > 0}),
        "axes": axes,
        "bbox_mm": None if not len(tips) else [_range(tips[:, k]) for k in range(3)],
        "b_deg": _range(motions.b_deg[known]),
        "feed_mm_min": _range(motions.feed),
        "machine_checks": machine_checks(moves, motions, machine),
        "other": dict(sorted(moves.other.items())),
    }


def format_program_summary(doc: dict) -> str:
    """The summary as a few lines of text."""
    b = doc["motions"]
    lines = [
        f"{doc['program']}: {doc['dialect']} G-code, {doc['units']}, machine {doc['machine']} "
        f"({doc['kind']})",
        f"  {doc['blocks']} blocks, {b['motion']} motions ({b['rapid']} rapid, {b['feed']} feed, "
        f"{b['arc']} arc, {b['cycle']} canned-cycle, {b['home']} home, {b['machine_frame']} "
        f"machine-frame; {b['tcp']} with tool-centre-point control)",
        f"  points: {doc['points']['known']} of {doc['points']['total']} known in the part frame",
        f"  tools: {', '.join(map(str, doc['tools'])) or '-'}; "
        f"feed: {doc['feed_mm_min']} mm/min",
        "  axes: " + " ".join(f"{k} {v}" for k, v in doc["axes"].items()),
    ]
    if doc["bbox_mm"]:
        x, y, z = doc["bbox_mm"]
        lines.append(f"  part-frame box: X {x} Y {y} Z {z} mm")
    if doc["other"]:
        lines.append("  other codes: " + ", ".join(f"{k} x{v}" for k, v in doc["other"].items()))
    checks = doc["machine_checks"]
    lines.append(f"  machine checks: {len(checks) or 'clean'}"
                 + (" finding(s)" if checks else ""))
    lines += [f"    {c['check']}: {c['message']}" for c in checks]
    return "\n".join(lines)
