"""Exact rational B-spline primitives (sphere, cylinder, flat patch) in mm, with normals out of
the solid: test parts and building blocks for samples."""

from __future__ import annotations

import numpy as np

from checker.part import Surface

_S = np.sqrt(0.5)
# full circle, degree 2, 9 poles (The NURBS Book, ex. 7.2): x, y, weight
_CIRCLE = np.array(
    [[1, 0, 1], [1, 1, _S], [0, 1, 1], [-1, 1, _S], [-1, 0, 1], [-1, -1, _S], [0, -1, 1],
     [1, -1, _S], [1, 0, 1]],
    dtype=np.float64,
)  # fmt: skip
_CIRCLE_KNOTS = np.array([0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1], dtype=np.float64)
# half circle from the south to the north pole: radial distance, height, weight
_HALF = np.array([[0, -1, 1], [1, -1, _S], [1, 0, 1], [1, 1, _S], [0, 1, 1]], dtype=np.float64)
_HALF_KNOTS = np.array([0, 0, 0, 0.5, 0.5, 1, 1, 1], dtype=np.float64)


def nurbs_sphere(radius: float, center=(0.0, 0.0, 0.0), surface_id: int = 0) -> Surface:
    """Sphere of `radius` mm: u around +z (counter-clockwise from +x), v from the south pole
    (v = 0) to the north pole (v = 1); normals point outwards."""
    c = np.asarray(center, dtype=np.float64)
    r, z, wp = _HALF[:, 0], _HALF[:, 1], _HALF[:, 2]
    x, y, wc = _CIRCLE[:, 0], _CIRCLE[:, 1], _CIRCLE[:, 2]
    ctrl = np.stack(
        [x[:, None] * r[None, :], y[:, None] * r[None, :], np.broadcast_to(z, (9, 5))], axis=2
    )
    return Surface(
        id=surface_id, name="sphere", kind="nurbs", degree_u=2, degree_v=2,
        knots_u=_CIRCLE_KNOTS, knots_v=_HALF_KNOTS, ctrlpts=c + radius * ctrl,
        weights=wc[:, None] * wp[None, :],
    )  # fmt: skip


def nurbs_cylinder(
    radius: float, z0: float, z1: float, surface_id: int = 0, inside: bool = False
) -> Surface:
    """Cylinder of `radius` mm about +z from height z0 to z1 (u around, v along +z). Normals
    point outwards (a shaft), or towards the axis with `inside` (a bore)."""
    x, y, wc = _CIRCLE[:, 0], _CIRCLE[:, 1], _CIRCLE[:, 2]
    ctrl = np.stack(
        [np.repeat(radius * x[:, None], 2, 1), np.repeat(radius * y[:, None], 2, 1),
         np.broadcast_to([z0, z1], (9, 2))],
        axis=2,
    )  # fmt: skip
    return Surface(
        id=surface_id, name="cylinder", kind="nurbs", degree_u=2, degree_v=1,
        knots_u=_CIRCLE_KNOTS, knots_v=np.array([0.0, 0.0, 1.0, 1.0]), ctrlpts=ctrl,
        weights=np.repeat(wc[:, None], 2, 1), flip=inside,
    )  # fmt: skip


def flat_patch(corner, edge_u, edge_v, surface_id: int = 0) -> Surface:
    """Bilinear parallelogram `corner + u edge_u + v edge_v`, u, v in [0, 1]; normal along
    edge_u x edge_v."""
    c, a, b = (np.asarray(t, dtype=np.float64) for t in (corner, edge_u, edge_v))
    ctrl = np.array([[c, c + b], [c + a, c + a + b]])
    k = np.array([0.0, 0.0, 1.0, 1.0])
    return Surface(
        id=surface_id, name="patch", kind="bspline", degree_u=1, degree_v=1,
        knots_u=k, knots_v=k, ctrlpts=ctrl,
    )  # fmt: skip
