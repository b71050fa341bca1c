"""What is in a CL file: `describe_toolpath(tp) -> dict` (the `pathcheck info --json` document)
and `format_toolpath_info(d) -> str` (its text view)."""

from __future__ import annotations

import math

import numpy as np

from checker.toolpath import RecordList, ToolPath
from checker.units import mm_per_unit

Z = np.array([0.0, 0.0, 1.0])


def axis_class(axis: np.ndarray, tol: float) -> str:
    """``"3-axis"`` when every unit axis (N, 3) is (0,0,1) within ``tol``; ``"4-axis-Y"`` when
    every axis has |j| <= tol (rotary table about Y, docs/MATH.md §1); else ``"multi-axis"``."""
    if len(axis) == 0 or max(float(np.abs(axis[:, c] - Z[c]).max()) for c in range(3)) <= tol:
        return "3-axis"
    if np.abs(axis[:, 1]).max() <= tol:
        return "4-axis-Y"
    return "multi-axis"


AXIS_DECIMALS = 3  # axes equal to 1e-3 (about 0.06 degrees) count as one orientation


def distinct_axes(axis: np.ndarray) -> int:
    """Number of different unit axis vectors (N, 3), compared to ``AXIS_DECIMALS`` decimals
    (each rounded component a whole number of thousandths, packed into one integer key)."""
    if len(axis) == 0:
        return 0
    q = 10**AXIS_DECIMALS
    base = 2 * q + 1  # a unit component rounds to one of -q .. q
    key = np.zeros(len(axis), dtype=np.int64)
    for c in range(3):
        key *= base
        key += np.rint(axis[:, c] * q).astype(np.int64) + q
    return len(np.unique(key))


def _bbox(tip: np.ndarray, scale: float) -> dict | None:
    if len(tip) == 0:
        return None
    return {
        "min": [round(float(v) / scale, 6) for v in tip.min(axis=0)],
        "max": [round(float(v) / scale, 6) for v in tip.max(axis=0)],
    }


def _cutter(c) -> dict | None:
    """The cutter in mm and degrees (None when the operation has none)."""
    if c is None:
        return None
    out = {"kind": c.kind}
    for key in ("d", "r", "R", "H"):
        out[key] = round(float(getattr(c, key)), 6)
    out["psi_deg"] = round(math.degrees(c.psi), 6)
    out["theta_deg"] = round(math.degrees(c.theta), 6)
    return out


def describe_toolpath(tp: ToolPath, axis_tol: float | None = None) -> dict:
    """Dialect, units, per-operation counts and axis class, totals, bounding box (in the file's
    units, part frame), unknown and ignored statements with counts. ``axis_tol`` defaults to
    the config's ``four_axis.axis_j_tolerance``."""
    if axis_tol is None:
        from checker.config import default_config

        axis_tol = default_config().four_axis.axis_j_tolerance
    m = tp.motions
    scale = mm_per_unit(tp.units)
    records = RecordList.of(tp.records)
    arc_op = m.op[[a.motion for a in tp.arcs]] if tp.arcs else np.zeros(0, dtype=np.int64)
    ops = []
    for k, op in enumerate(tp.operations):
        mot = slice(op.first_motion, op.end_motion)
        ax = m.axis[mot]
        goto, goto_axis = records.goto_counts(op.first_record, op.end_record)
        ops.append(
            {
                "name": op.name,
                "tool": op.tool_name,
                "tool_number": op.tool_number,
                "cutter": _cutter(op.cutter),
                "records": op.end_record - op.first_record,
                "goto": goto,
                "goto_with_axis": goto_axis,
                "rapid": int(m.rapid[mot].sum()),
                "arcs": int((arc_op == k).sum()),
                "distinct_axes": distinct_axes(ax),
                "axis_class": axis_class(ax, axis_tol),
                "first_line": records[op.first_record].line if op.end_record > op.first_record
                else None,
                "bbox": _bbox(m.tip[mot], scale),
            }
        )
    goto_total, axis_total = records.goto_counts(0, len(records))
    return {
        "file": tp.path,
        "dialect": tp.dialect,
        "units": tp.units,
        "operations": ops,
        "totals": {
            "operations": len(ops),
            "records": len(records),
            "goto": goto_total,
            "goto_with_axis": axis_total,
            "rapid": int(m.rapid.sum()),
            "arcs": len(tp.arcs),
            "motions": len(m),
            "tool_changes": len(tp.tool_changes),
            "distinct_axes": distinct_axes(m.axis),
            "axis_class": axis_class(m.axis, axis_tol),
        },
        "bbox": _bbox(m.tip, scale),
        "frames": [
            {"word": f.word, "line": f.line, "applied": f.applied} for f in tp.frames
        ],
        "unknown": dict(sorted(tp.unknown.items())),
        "ignored": dict(sorted(tp.ignored.items())),
    }


def _fmt_box(b: dict | None) -> str:
    if b is None:
        return "-"
    return " .. ".join("(" + ", ".join(f"{v:.4g}" for v in b[k]) + ")" for k in ("min", "max"))


def format_toolpath_info(d: dict) -> str:
    """A short text view of `describe_toolpath`'s document."""
    t = d["totals"]
    lines = [
        f"{d['file']}: {d['dialect']} CL, units {d['units']}, {t['operations']} operation(s), "
        f"{t['records']} records",
        f"  totals: {t['goto']} GOTO ({t['goto_with_axis']} with axis, {t['rapid']} rapid), "
        f"{t['arcs']} arcs, {t['distinct_axes']} distinct axes, {t['axis_class']}",
        f"  bbox ({d['units']}): {_fmt_box(d['bbox'])}",
    ]
    head = f"  {'#':>3} {'operation':<32} {'tool':<18} {'GOTO':>6} {'axis':>6} {'rapid':>6} " \
        f"{'arcs':>5} {'axes':>5}  class"
    lines.append(head)
    for k, op in enumerate(d["operations"], start=1):
        tool = op["tool"] or "-"
        lines.append(
            f"  {k:>3} {op['name'][:32]:<32} {tool[:18]:<18} {op['goto']:>6} "
            f"{op['goto_with_axis']:>6} {op['rapid']:>6} {op['arcs']:>5} "
            f"{op['distinct_axes']:>5}  {op['axis_class']}"
        )
    if d["unknown"]:
        lines.append(
            "  unknown statements: " + ", ".join(f"{w} x{n}" for w, n in d["unknown"].items())
        )
    return "\n".join(lines)
