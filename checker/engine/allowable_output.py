"""The JSON document and the text table of `pathcheck allowable` (views of AllowableResult)."""

from __future__ import annotations

import math

import numpy as np

from checker.engine.api import AllowableResult


def _num(x: float, nd: int = 6) -> float | None:
    return None if not math.isfinite(float(x)) else round(float(x), nd)


def _vec(v: np.ndarray, nd: int = 6) -> list[float] | None:
    return None if not np.isfinite(v).all() else [round(float(t), nd) for t in v]


def allowable_document(res: AllowableResult, cc: np.ndarray, normals: np.ndarray, cutter,
                       method: str, timing: dict[str, float]) -> dict:
    """`points[] {index, cc, normal, allowable, limiting_point, limiting_surface, advice,
    margin, evaluations}` (mm; allowable null = unbounded), the cutter and `timing` (s)."""
    points = [
        {
            "index": i,
            "cc": _vec(cc[i]),
            "normal": _vec(normals[i], 9),
            "allowable": _num(res.size[i]),
            "limiting_point": _vec(res.limiting_point[i]),
            "limiting_surface": (None if res.limiting_surface[i] < 0
                                 else int(res.limiting_surface[i])),
            "advice": str(res.advice[i]),
            "margin": _num(res.margin[i]),
            "evaluations": int(res.evaluations[i]),
        }
        for i in range(len(cc))
    ]
    return {
        "cutter": {"apt": cutter.to_apt(), "kind": cutter.kind, "size": float(cutter.size),
                   "variable": cutter.size_symbol},
        "method": method,
        "points": points,
        "timing": {k: round(v, 6) for k, v in timing.items()},
    }


def allowable_table(doc: dict, limit: int = 60):
    """A rich Table of the points (the first `limit`)."""
    from rich.table import Table

    var = doc["cutter"]["variable"]
    t = Table(title=f"allowable {var} for {doc['cutter']['apt']} ({doc['method']})")
    four = bool(doc["points"]) and "b_best" in doc["points"][0]
    cols = ["#", "cc (mm)", f"allowable {var}", "limiting point", "surf", "advice"]
    if four:
        cols += ["best B (deg)", f"{var} at best", "feasible B (deg)"]
    for col in cols:
        t.add_column(col, justify="right" if col in ("#", "surf") else "left")
    fmt = lambda v: "-" if v is None else ", ".join(f"{x:.3f}" for x in v)  # noqa: E731
    size = lambda v: "unbounded" if v is None else f"{v:.4f}"  # noqa: E731
    for p in doc["points"][:limit]:
        s = "-" if p["limiting_surface"] is None else str(p["limiting_surface"])
        row = [str(p["index"]), fmt(p["cc"]), size(p["allowable"]), fmt(p["limiting_point"]), s,
               p["advice"]]
        if four:
            feasible = " ".join(f"[{lo:.2f}, {hi:.2f}]" for lo, hi in p["b_feasible"]) or "none"
            row += [f"{p['b_best']:.2f}", size(p["allowable_at_best"]), feasible]
        t.add_row(*row)
    return t
