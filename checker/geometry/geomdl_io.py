"""geomdl exchange JSON/YAML (the native part format): one or many surfaces as written by
`geomdl.exchange.export_json` (a surface or a `multi.SurfaceContainer`), with optional trims.

Read with the json/yaml parsers directly (no geomdl objects): poles are Cartesian in mm, listed
u-major (v fastest) as geomdl stores them; `weights` make the surface rational; `reversed`
flips the normal. Trim curves (in (u, v)) are sampled into loops: `reversed = 1` keeps the
inside of the curve, otherwise the inside is cut away (geomdl's convention).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml

from checker.errors import PathcheckError
from checker.geometry.trims import UVTrim
from checker.part import Surface

_TRIM_SAMPLES_PER_SPAN = 32


def read_geomdl(path: Path, text: str) -> list[Surface]:
    """Surfaces of a geomdl exchange file whose content is `text`."""
    try:
        data = (
            yaml.safe_load(text) if path.suffix.lower() in (".yaml", ".yml") else json.loads(text)
        )
    except (json.JSONDecodeError, yaml.YAMLError) as err:
        raise PathcheckError(
            f"not valid geomdl exchange data: {err}", path=path, code="part"
        ) from err
    shape = data.get("shape") if isinstance(data, dict) else None
    if not isinstance(shape, dict) or not isinstance(shape.get("data"), list):
        raise PathcheckError(
            "expected a geomdl exchange document {'shape': {'type': 'surface', "
            "'data': [...]}}, found no 'shape.data' list",
            path=path,
            code="part",
        )
    if shape.get("type") != "surface":
        raise PathcheckError(
            f"expected shape type 'surface', found {shape.get('type')!r}", path=path, code="part"
        )
    return [_surface(path, i, d) for i, d in enumerate(shape["data"])]


def _surface(path: Path, index: int, d: dict) -> Surface:
    where = f"surface {index}"
    try:
        p, q = int(d["degree_u"]), int(d["degree_v"])
        nu, nv = int(d["size_u"]), int(d["size_v"])
        pts = np.asarray(d["control_points"]["points"], dtype=np.float64)
        if pts.shape != (nu * nv, 3):
            dim = pts.shape[1] if pts.ndim == 2 else "?"
            found = f"{len(pts)} control points with {dim} coordinates"
            raise ValueError(f"{found}, expected {nu}x{nv} = {nu * nv} points with x, y, z")
        w = d["control_points"].get("weights")
        weights = None if w is None else np.asarray(w, dtype=np.float64).reshape(nu, nv)
        if weights is not None and np.ptp(weights) == 0.0:
            weights = None  # all-equal weights: a polynomial surface
        name = str(d.get("name") or f"surface_{index}")
        surf = Surface(
            id=index,
            name=name,
            kind="nurbs" if weights is not None else "bspline",
            degree_u=p,
            degree_v=q,
            knots_u=np.asarray(d["knotvector_u"], dtype=np.float64),
            knots_v=np.asarray(d["knotvector_v"], dtype=np.float64),
            ctrlpts=pts.reshape(nu, nv, 3),
            weights=weights,
            flip=bool(d.get("reversed", 0)),
        )
        if np.any(np.diff(surf.knots_u) < 0) or np.any(np.diff(surf.knots_v) < 0):
            raise ValueError("knot vector is not non-decreasing")
        if weights is not None and np.any(weights <= 0):
            raise ValueError("weights must be positive")
        if "trims" in d:
            surf.trim = _trim(d["trims"])
    except KeyError as err:
        raise PathcheckError(
            f"{where}: missing key {err.args[0]!r}", path=path, code="part"
        ) from err
    except (ValueError, TypeError) as err:
        raise PathcheckError(f"{where}: {err}", path=path, code="part") from err
    return surf


def _trim(trims: dict) -> UVTrim | None:
    outer, holes = [], []
    for t in trims.get("data", []):
        loop = _trim_loop(t)
        (outer if t.get("reversed", 0) else holes).append(loop)
    return UVTrim(outer, holes) if outer or holes else None


def _trim_loop(t: dict) -> np.ndarray:
    """(K, 2) polyline of a trim curve: spline, freeform points or a container of curves."""
    kind = t.get("type")
    if kind == "freeform":
        return np.asarray(t["points"], dtype=np.float64)[:, :2]
    if kind == "container":
        return np.concatenate([_trim_loop(c) for c in t["data"]])
    if kind != "spline":
        raise ValueError(f"trim curve type {kind!r}, expected spline, freeform or container")
    return _curve_points(t)


def _curve_points(t: dict) -> np.ndarray:
    """Sample a 2-D (rational) B-spline trim curve, uniformly within each knot span."""
    from scipy.interpolate import BSpline

    p = int(t["degree"])
    kv = np.asarray(t["knotvector"], dtype=np.float64)
    pts = np.asarray(t["control_points"]["points"], dtype=np.float64)[:, :2]
    w = np.asarray(t["control_points"].get("weights", np.ones(len(pts))), dtype=np.float64)
    knots = np.unique(kv[p : len(kv) - p])
    s = np.linspace(0.0, 1.0, _TRIM_SAMPLES_PER_SPAN, endpoint=False)
    x = np.append((knots[:-1, None] + s * np.diff(knots)[:, None]).ravel(), knots[-1])
    hom = BSpline(kv, np.column_stack([pts * w[:, None], w]), p)(x)
    return hom[:, :2] / hom[:, 2:3]
