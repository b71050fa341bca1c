"""What is in a part file: surfaces (kind, degrees, poles, rational, trimmed), bounding box, units
(`describe_part`), and its plain-text view (`format_part_info`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from checker.part import Part

_BBOX_GRID = 33


def part_bbox(part: Part) -> np.ndarray:
    """(2, 3) [min, max] in mm of the kept part: mesh vertices, or each surface evaluated on a
    33 x 33 grid per surface plus its trim loops (grid points in trimmed-away regions skipped)."""
    from checker.geometry.evaluate import evaluate

    if part.mesh is not None:
        return np.array([part.mesh.vertices.min(axis=0), part.mesh.vertices.max(axis=0)])
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        U, V = np.meshgrid(np.linspace(u0, u1, _BBOX_GRID), np.linspace(v0, v1, _BBOX_GRID))
        u, v = U.ravel(), V.ravel()
        if s.trim is not None:
            keep = s.trim.contains(u, v)
            loops = np.concatenate(s.trim.loops)
            u, v = np.append(u[keep], loops[:, 0]), np.append(v[keep], loops[:, 1])
        p = evaluate(s, u, v).points
        lo, hi = np.minimum(lo, p.min(axis=0)), np.maximum(hi, p.max(axis=0))
    return np.array([lo, hi])


def describe_part(path: str | Path) -> dict:
    """JSON-ready summary of a part file (raises PathcheckError(code="part") for bad files)."""
    from checker.geometry import load_part

    part = load_part(path)
    bbox = part.bbox
    surfaces = [
        {
            "id": s.id,
            "name": s.name,
            "kind": s.kind,
            "degree_u": s.degree_u,
            "degree_v": s.degree_v,
            "poles_u": int(s.ctrlpts.shape[0]),
            "poles_v": int(s.ctrlpts.shape[1]),
            "rational": s.rational,
            "trimmed": s.trim is not None,
        }
        for s in part.surfaces
    ]
    out = {
        "source": part.source,
        "units": part.units,
        "faces": part.faces,
        "kind": "mesh" if part.mesh is not None else "nurbs",
        "content_hash": part.content_hash,
        "surfaces": surfaces,
        "bbox": {"min": bbox[0].tolist(), "max": bbox[1].tolist()},
    }
    if part.mesh is not None:
        out["mesh"] = {
            "vertices": int(len(part.mesh.vertices)),
            "triangles": int(len(part.mesh.triangles)),
        }
    return out


def _mm(xyz) -> str:
    """'x, y, z' to 1 um, without negative zeros."""
    return ", ".join(f"{round(x, 3) + 0.0:.3f}" for x in xyz)


def format_part_info(d: dict) -> str:
    """Plain-text view of `describe_part`'s dict: one header, one line per surface."""
    lo, hi = d["bbox"]["min"], d["bbox"]["max"]
    size = [h - lo_ for lo_, h in zip(lo, hi, strict=True)]
    lines = [
        f"part {d['source']}",
        f"  units {d['units']}, {d['faces']} faces, bbox "
        f"[{_mm(lo)}] .. [{_mm(hi)}] (size {' x '.join(f'{x:.3f}' for x in size)})",
    ]
    if "mesh" in d:
        lines.append(
            f"  mesh: {d['mesh']['vertices']} vertices, {d['mesh']['triangles']} triangles"
        )
        return "\n".join(lines)
    n_rat = sum(s["rational"] for s in d["surfaces"])
    n_trim = sum(s["trimmed"] for s in d["surfaces"])
    lines.append(f"  {len(d['surfaces'])} surfaces ({n_rat} rational, {n_trim} trimmed)")
    lines.append(f"  {'id':>4}  {'kind':<10} {'degree':>7} {'poles':>9}  flags  name")
    for s in d["surfaces"]:
        flags = ("R" if s["rational"] else "-") + ("T" if s["trimmed"] else "-")
        lines.append(
            f"  {s['id']:>4}  {s['kind']:<10} {s['degree_u']:>3}x{s['degree_v']:<3} "
            f"{s['poles_u']:>4}x{s['poles_v']:<4}  {flags:<5}  {s['name']}"
        )
    return "\n".join(lines)
