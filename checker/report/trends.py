"""Trends against previous nights: the recorded jobs grouped into 24-hour windows ending at the
report time (window 0 is tonight), and per-night totals to compare tonight with."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime

import numpy as np

from checker.store import JobRow

DAY_S = 86400.0


def local_iso(t: float) -> str:
    """UTC epoch seconds as ISO 8601 local time with its offset, 2026-11-24T07:09:00+01:00: how
    the report shows and exports every date (the store keeps epoch seconds)."""
    return datetime.fromtimestamp(t).astimezone().isoformat(timespec="seconds")


def night_label(end: float) -> str:
    """The local date (YYYY-MM-DD) on which a night's window ends: the morning of the report."""
    return local_iso(end)[:10]


def nights(rows: Sequence[JobRow], until: float, count: int) -> list[dict]:
    """Per-night totals of the `count` 24-hour windows ending at `until` (UTC epoch s), oldest
    first: night (label), start (UTC epoch s), jobs, ok, findings, failed, gouges (gouge points),
    interference, holder (points), worst_depth (mm, None if no depth)."""
    t = np.array([r.recorded_at for r in rows], dtype=float)
    k = np.floor((until - t) / DAY_S).astype(int)  # 0 = tonight
    out = []
    for night in range(count - 1, -1, -1):
        sel = [r for r, kk in zip(rows, k, strict=True) if kk == night]
        depths = [r.worst_depth for r in sel if r.worst_depth is not None]
        start = until - (night + 1) * DAY_S
        out.append({
            "night": night_label(start + DAY_S),
            "start": start,
            "jobs": len(sel),
            **{s: sum(r.status == s for r in sel) for s in ("ok", "findings", "failed")},
            "gouges": sum(r.n_gouge or 0 for r in sel),
            "interference": sum(r.n_interference or 0 for r in sel),
            "holder": sum(r.n_holder or 0 for r in sel),
            "worst_depth": max(depths) if depths else None,
        })
    return out


def compare(per_night: list[dict]) -> list[tuple[str, float | None, float | None, float | None]]:
    """(quantity, tonight, previous night, mean of the nights before tonight) for the trend
    table; None where there is no such night."""
    tonight = per_night[-1] if per_night else None
    before = per_night[:-1]
    previous = before[-1] if before else None
    out = []
    for key in ("jobs", "failed", "findings", "gouges", "interference", "holder", "worst_depth"):
        values = [n[key] for n in before if n[key] is not None]
        out.append((
            key.replace("_", " "),
            tonight[key] if tonight else None,
            previous[key] if previous else None,
            float(np.mean(values)) if values else None,
        ))
    return out
