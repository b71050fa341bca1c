"""geomdl exchange JSON/YAML (the native part format): one or many surfaces as written by
`geomdl.exchange.export_json` (a surface or a `multi.SurfaceContainer`), with optional trims.

Read with the json/yaml parsers directly (no geomdl objects): poles are Cartesian in mm, listed
u-major (v fastest) as geomdl stores them; `weights` make the surface rational; `reversed`
flips the normal. Trim curves (in (u, v)) are sampled into loops: `reversed = 1` keeps the
inside of the curve, otherwise the inside is cut away (geomdl's convention).

Hostile documents are bounded before any number is used: nesting deeper than `MAX_DEPTH`, YAML
whose aliases would expand to more than `_yaml_node_limit` nodes, and any value out of the
ranges of `checker.geometry.part_limits` are one error naming the file and the surface.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import yaml

from checker.errors import PathcheckError
from checker.geometry.part_limits import (
    MAX_DEGREE,
    MAX_TRIM_POINTS,
    check_coordinates,
    check_degree,
    check_knots,
    check_weights,
)
from checker.geometry.trims import UVTrim
from checker.part import Surface

_TRIM_SAMPLES_PER_SPAN = 32
MAX_DEPTH = 64  # nesting of lists and mappings (a geomdl document needs about 10)
_MAX_CONTAINER_DEPTH = 8  # trim containers inside trim containers


class _DocumentError(ValueError):
    """A document-level problem (not tied to one surface)."""


class _BoundedYamlLoader(yaml.SafeLoader):
    """PyYAML's safe loader (pure Python: libyaml's composer crashes on deep nesting) that stops
    at MAX_DEPTH levels and when aliases would expand the document beyond `node_limit` nodes
    (the expanded size of every node is counted once, so an alias bomb costs its own size)."""

    def __init__(self, stream: str, node_limit: int) -> None:
        super().__init__(stream)
        self._depth = 0
        self._size: dict[int, int] = {}
        self._node_limit = node_limit

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            node = super().compose_node(parent, index)
            if id(node) not in self._size:
                raise _DocumentError("recursive YAML alias (an anchor used inside itself)")
            return node
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise _DocumentError(f"nested deeper than {MAX_DEPTH} levels")
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        kids = node.value if isinstance(node.value, list) else []
        flat = [n for kid in kids for n in (kid if isinstance(kid, tuple) else (kid,))]
        size = 1 + sum(self._size[id(n)] for n in flat)
        if size > self._node_limit:
            raise _DocumentError(f"YAML aliases expand to more than {self._node_limit} values")
        self._size[id(node)] = size
        return node


def _yaml_node_limit(text: str) -> int:
    """Values a YAML document may expand to: 4 per character plus 100,000 (a document without
    aliases holds fewer values than characters)."""
    return 4 * len(text) + 100_000


def _parse(path: Path, text: str):
    try:
        if path.suffix.lower() in (".yaml", ".yml"):
            loader = _BoundedYamlLoader(text, _yaml_node_limit(text))
            try:
                return loader.get_single_data()
            finally:
                loader.dispose()
        return json.loads(text)
    except RecursionError as err:  # json: deeper than the interpreter's recursion limit
        raise _DocumentError("nested too deeply") from err
    except _DocumentError:
        raise
    except (json.JSONDecodeError, yaml.YAMLError) as err:
        raise _DocumentError(f"not valid geomdl exchange data: {err}") from err
    except ValueError as err:  # e.g. an integer of more than 4300 digits
        raise _DocumentError(f"not valid geomdl exchange data: {err}") from err


def read_geomdl(path: Path, text: str) -> list[Surface]:
    """Surfaces of a geomdl exchange file whose content is `text`."""
    try:
        data = _parse(path, text)
    except _DocumentError as err:
        raise PathcheckError(str(err), path=path, code="part") from err
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
            f"expected shape type 'surface', found {str(shape.get('type'))[:40]!r}",
            path=path,
            code="part",
        )
    return [_surface(path, i, d) for i, d in enumerate(shape["data"])]


def _floats(value: object, what: str) -> np.ndarray:
    """`value` as a float64 array; the error says which field."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (ValueError, TypeError, OverflowError) as err:
        raise ValueError(f"{what}: expected numbers ({str(err)[:80]})") from err


def _count(value: object, what: str, limit: int) -> int:
    """A positive integer count of at most `limit`."""
    ok = isinstance(value, int) or (isinstance(value, float) and math.isfinite(value)
                                    and value.is_integer())
    if isinstance(value, bool) or not ok or not 1 <= value <= limit:
        raise ValueError(f"{what} {str(value)[:40]} out of range, expected 1..{limit}")
    return int(value)


def _field(d: dict, key: str) -> object:
    if key not in d:
        raise KeyError(key)
    return d[key]


def _surface(path: Path, index: int, d: object) -> Surface:
    where = f"surface {index}"
    try:
        if not isinstance(d, dict):
            raise ValueError(f"expected a surface object, found {type(d).__name__}")
        p = check_degree(_field(d, "degree_u"), "degree_u")
        q = check_degree(_field(d, "degree_v"), "degree_v")
        cp = _field(d, "control_points")
        if not isinstance(cp, dict):
            raise ValueError("control_points: expected an object with 'points'")
        pts = _floats(_field(cp, "points"), "control_points.points")
        npts = pts.shape[0] if pts.ndim else 0
        nu = _count(_field(d, "size_u"), "size_u", max(1, npts))
        nv = _count(_field(d, "size_v"), "size_v", max(1, npts))
        if pts.shape != (nu * nv, 3):
            dim = pts.shape[1] if pts.ndim == 2 else "?"
            found = f"{npts} control points with {dim} coordinates"
            raise ValueError(f"{found}, expected {nu}x{nv} = {nu * nv} points with x, y, z")
        check_coordinates(pts, "control_points")
        w = cp.get("weights")
        weights = None if w is None else _floats(w, "weights")
        if weights is not None:
            if weights.size != nu * nv:
                raise ValueError(f"{weights.size} weights, expected {nu * nv}")
            weights = weights.reshape(nu, nv)
            check_weights(weights, "weights")
            if np.ptp(weights) == 0.0:
                weights = None  # all-equal weights: a polynomial surface
        ku = _floats(_field(d, "knotvector_u"), "knotvector_u").ravel()
        kv = _floats(_field(d, "knotvector_v"), "knotvector_v").ravel()
        name = str(d.get("name") or f"surface_{index}")[:200]
        surf = Surface(
            id=index,
            name=name,
            kind="nurbs" if weights is not None else "bspline",
            degree_u=p,
            degree_v=q,
            knots_u=ku,
            knots_v=kv,
            ctrlpts=pts.reshape(nu, nv, 3),
            weights=weights,
            flip=bool(d.get("reversed", 0)),
        )
        check_knots(surf.knots_u, p, "knotvector_u")
        check_knots(surf.knots_v, q, "knotvector_v")
        if "trims" in d:
            surf.trim = _trim(d["trims"])
    except KeyError as err:
        raise PathcheckError(
            f"{where}: missing key {str(err.args[0])[:40]!r}", path=path, code="part"
        ) from err
    except (ValueError, TypeError) as err:
        raise PathcheckError(f"{where}: {err}", path=path, code="part") from err
    return surf


def _trim(trims: object) -> UVTrim | None:
    if not isinstance(trims, dict) or not isinstance(trims.get("data", []), list):
        raise ValueError("trims: expected an object with a 'data' list")
    outer, holes, budget = [], [], [MAX_TRIM_POINTS]
    for i, t in enumerate(trims.get("data", [])):
        loop = _trim_loop(t, f"trims.data[{i}]", budget, 0)
        (outer if t.get("reversed", 0) else holes).append(loop)
    return UVTrim(outer, holes) if outer or holes else None


def _trim_loop(t: object, where: str, budget: list[int], depth: int) -> np.ndarray:
    """(K, 2) polyline of a trim curve: spline, freeform points or a container of curves.
    `budget[0]` is the number of trim points the surface may still take."""
    if not isinstance(t, dict):
        raise ValueError(f"{where}: expected a trim curve object, found {type(t).__name__}")
    kind = t.get("type")
    if kind == "freeform":
        pts = _floats(_field(t, "points"), f"{where}.points")
        if pts.ndim != 2 or pts.shape[1] < 2:
            raise ValueError(f"{where}.points: expected a list of (u, v) points")
        out = pts[:, :2]
    elif kind == "container":
        if depth >= _MAX_CONTAINER_DEPTH or not isinstance(t.get("data"), list):
            raise ValueError(f"{where}: expected a 'data' list of curves, nested at most "
                             f"{_MAX_CONTAINER_DEPTH} deep")
        parts = [_trim_loop(c, f"{where}.data[{i}]", budget, depth + 1)
                 for i, c in enumerate(t["data"])]
        return np.concatenate(parts) if parts else np.zeros((0, 2))
    elif kind == "spline":
        out = _curve_points(t, where, budget[0])
    else:
        raise ValueError(f"{where}: trim curve type {str(kind)[:40]!r}, expected spline, "
                         "freeform or container")
    if not np.isfinite(out).all():
        raise ValueError(f"{where}: non-finite trim point")
    budget[0] -= len(out)
    if budget[0] < 0:
        raise ValueError(f"{where}: more than {MAX_TRIM_POINTS} trim points")
    return out


def _curve_points(t: dict, where: str, budget: int) -> np.ndarray:
    """Sample a 2-D (rational) B-spline trim curve, uniformly within each knot span (up to
    32 points per span, fewer when the spans are many: at most `budget` points in all)."""
    from scipy.interpolate import BSpline

    p = _count(_field(t, "degree"), f"{where}.degree", MAX_DEGREE)
    kv = _floats(_field(t, "knotvector"), f"{where}.knotvector").ravel()
    cp = _field(t, "control_points")
    if not isinstance(cp, dict):
        raise ValueError(f"{where}.control_points: expected an object with 'points'")
    pts = _floats(_field(cp, "points"), f"{where}.control_points.points")
    if pts.ndim != 2 or pts.shape[1] < 2 or len(kv) != len(pts) + p + 1:
        raise ValueError(f"{where}: {len(kv)} knots and {len(pts)} points do not fit degree {p}")
    pts = pts[:, :2]
    if not np.isfinite(pts).all():
        raise ValueError(f"{where}: non-finite control point")
    check_knots(kv, p, f"{where}.knotvector")
    w = cp.get("weights")
    w = np.ones(len(pts)) if w is None else _floats(w, f"{where}.weights").ravel()
    if w.shape != (len(pts),):
        raise ValueError(f"{where}: {w.size} weights for {len(pts)} control points")
    check_weights(w, f"{where}.weights")
    knots = np.unique(kv[p : len(kv) - p])
    spans = len(knots) - 1
    if spans + 1 > budget:
        raise ValueError(f"{where}: {spans} knot spans, more than {budget} trim points left")
    per_span = int(min(_TRIM_SAMPLES_PER_SPAN, max(1, (budget - 1) // spans)))
    s = np.linspace(0.0, 1.0, per_span, endpoint=False)
    x = np.append((knots[:-1, None] + s * np.diff(knots)[:, None]).ravel(), knots[-1])
    hom = BSpline(kv, np.column_stack([pts * w[:, None], w]), p)(x)
    return hom[:, :2] / hom[:, 2:3]
