"""An independent oracle for `checker.mesh.pose_depths`: OpenCAMLib's drop-cutter.

`ocl_depth(vertices, triangles, cutter, tips, axes) -> (N,)` the penetration depth (mm) of the
body of a flat, ball or bull-nose `cutter` (unbounded upwards) into the mesh at each pose, 0 where
it does not penetrate (this oracle does not measure clearances).

Why this measures the same thing as `pose_depths`. For a solid C and a set S the depth is
sup{d : C (-) dB meets S} (C (-) dB the erosion of C by a ball of radius d: the points at least d
inside C); 0 when C does not meet S. The erosion of these cutters is again a cutter of the same
kind, raised by d along the axis (the Minkowski argument: C = K (+) rB with K the core, so
C (-) dB = K (+) (r - d)B for d <= r, and a cylinder of radius a from height h0 eroded by d is
the cylinder of radius a - d from h0 + d):
- flat D: a flat of diameter D - 2d, tip raised by d;
- ball r: a ball of radius r - d (diameter 2 (r - d)), tip raised by d;
- bull-nose D, r: a bull-nose D - 2d, r - d while d < r, then a flat D - 2d; tip raised by d.
Drop-cutter gives, for a cutter over (x, y) (axis +z, unbounded upwards), the lowest tip height z
at which the cutter does not cut any triangle: a cutter with its tip at height z meets the mesh
iff z < drop(x, y) (it is unbounded upwards, so it meets the mesh for every lower z). Hence the
eroded cutter meets the mesh iff tip_z + d < drop_d(x, y), a predicate that is monotone in d
(the eroded solids are nested), and the depth is its supremum, found by bisection (regula falsi
with the Illinois rule) to `tol`. Mesh and poses are rotated so that the axis is +z (one
rotation per distinct axis).

Limits: drop-cutter treats the cutter as unbounded upwards (so must the compared tool be: no
flute length, H = 0, no shank or holder); cone cutters (APT bottom angle, taper) and tapered balls
are not covered; the oracle gives no clearance (0 for any clear pose); the bisection is as good as
OCL's own drop-cutter precision (about 1e-7 mm here).

The first stage (is the real cutter in the material at all?) runs every pose of an axis through
one `ocl.BatchDropCutter` call; the bisection then drops each pose's eroded cutters on the
triangles under the real cutter (a numpy box test in the rotated frame), one `dropCutter` call per
triangle.
"""

from __future__ import annotations

import numpy as np
import opencamlib as ocl

_LENGTH = 1e4       # mm: OCL's cutter length (drop-cutter does not use it to bound the cutter)


def rotation_to_z(axis: np.ndarray) -> np.ndarray:
    """A rotation matrix Q (3, 3) with Q @ axis = (0, 0, 1)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    v = np.cross(a, [0.0, 0.0, 1.0])
    s, c = np.linalg.norm(v), float(a[2])
    if s < 1e-15:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = v / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * kx + (1 - c) * kx @ kx


def eroded_cutter(cutter, d: float):
    """The OCL cutter of `cutter` (flat, ball, bull-nose) eroded by d (its tip raised by d)."""
    R = 0.0 if cutter.kind == "ball" else float(cutter.R)
    r = float(cutter.r)
    if cutter.kind == "flat" or (cutter.kind == "bullnose" and r - d <= 1e-7):
        return ocl.CylCutter(2.0 * (R + r - d), _LENGTH)
    if cutter.kind == "ball":
        return ocl.BallCutter(2.0 * (r - d), _LENGTH)
    if cutter.kind == "bullnose":
        return ocl.BullCutter(2.0 * (R + r - d), r - d, _LENGTH)
    raise ValueError(f"the OCL oracle covers flat, ball and bull-nose cutters, not {cutter.kind}")


def _surface(tri: np.ndarray) -> tuple[ocl.STLSurf, list]:
    surf = ocl.STLSurf()
    tris = []
    for a, b, c in tri:
        t = ocl.Triangle(ocl.Point(*a), ocl.Point(*b), ocl.Point(*c))
        surf.addTriangle(t)
        tris.append(t)
    return surf, tris


def drop_heights(surf: ocl.STLSurf, cutter, xy: np.ndarray, z0: float,
                 threads: int = 1) -> np.ndarray:
    """Drop-cutter tip heights (N,) of the OCL `cutter` at the points xy (N, 2) over `surf`, from
    z0 (below the mesh) in one BatchDropCutter run."""
    bdc = ocl.BatchDropCutter()
    bdc.setSTL(surf)
    bdc.setCutter(cutter)
    bdc.setThreads(threads)
    for x, y in xy:
        bdc.appendPoint(ocl.CLPoint(float(x), float(y), z0))
    bdc.run()
    return np.array([p.z for p in bdc.getCLPoints()])


def _drop_one(cutter, x: float, y: float, z0: float, tris: list) -> float:
    cl = ocl.CLPoint(x, y, z0)
    for t in tris:
        cutter.dropCutter(cl, t)
    return cl.z


def ocl_depth(vertices: np.ndarray, triangles: np.ndarray, cutter, tips: np.ndarray,
              axes: np.ndarray, tol: float = 1e-7) -> np.ndarray:
    """(N,) depth (mm, >= 0) of `cutter`'s body (unbounded upwards) into the mesh at the poses
    `tips (N, 3)`, `axes (N, 3)` or `(3,)` (part frame), by drop-cutter (module docstring)."""
    tips = np.asarray(tips, dtype=float).reshape(-1, 3)
    axes = np.broadcast_to(np.asarray(axes, dtype=float), tips.shape)
    axes = axes / np.linalg.norm(axes, axis=1)[:, None]
    tri = np.asarray(vertices, dtype=float)[np.asarray(triangles)]
    radius = (0.0 if cutter.kind == "ball" else float(cutter.R)) + float(cutter.r)
    dmax = radius
    out = np.zeros(len(tips))
    keys = np.round(axes, 12)
    _, group = np.unique(keys, axis=0, return_inverse=True)
    for g in np.unique(group):
        rows = np.flatnonzero(group == g)
        Q = rotation_to_z(axes[rows[0]])
        rt = tri @ Q.T
        surf, _ = _surface(rt)
        p = tips[rows] @ Q.T
        z0 = float(rt[..., 2].min()) - 10.0 * radius - 10.0
        drop0 = drop_heights(surf, eroded_cutter(cutter, 0.0), p[:, :2], z0)
        lo_xy = rt[..., :2].min(axis=1)
        hi_xy = rt[..., :2].max(axis=1)
        for j in np.flatnonzero(drop0 - p[:, 2] > 1e-9):
            x, y, z = p[j]
            near = np.flatnonzero((lo_xy[:, 0] <= x + radius) & (hi_xy[:, 0] >= x - radius)
                                  & (lo_xy[:, 1] <= y + radius) & (hi_xy[:, 1] >= y - radius))
            tris = [ocl.Triangle(ocl.Point(*rt[k, 0]), ocl.Point(*rt[k, 1]),
                                 ocl.Point(*rt[k, 2])) for k in near]

            def gap(d, x=x, y=y, z=z, z0=z0, tris=tris):
                """drop height of the d-eroded cutter minus its raised tip: > 0 while it cuts"""
                return _drop_one(eroded_cutter(cutter, d), x, y, z0, tris) - (z + d)

            out[rows[j]] = _root(gap, drop0[j] - z, dmax, tol)
    return out


def _root(gap, g0: float, dmax: float, tol: float) -> float:
    """sup{d in [0, dmax) : gap(d) > 0} for gap decreasing with gap(0) = g0 > 0: regula falsi
    with the Illinois rule, bisection where it stalls."""
    a, ga = 0.0, g0
    b = dmax * (1.0 - 1e-9)
    gb = gap(b)
    if gb > 0.0:
        return dmax
    side = 0
    for _ in range(200):
        if b - a <= tol:
            break
        c = (a * gb - b * ga) / (gb - ga)
        if not (a < c < b) or side == 3 or side == -3:
            c = 0.5 * (a + b)
            side = 0
        gc = gap(c)
        if gc > 0.0:
            a, ga = c, gc
            gb = gb * 0.5 if side < 0 else gb
            side = min(side, 0) - 1
        else:
            b, gb = c, gc
            ga = ga * 0.5 if side > 0 else ga
            side = max(side, 0) + 1
    return 0.5 * (a + b)


__all__ = ["drop_heights", "eroded_cutter", "ocl_depth", "rotation_to_z"]
