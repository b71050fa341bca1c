"""The allowable cutter size on a mesh: the largest size of a cutter family whose body, touching
a contact point, penetrates the mesh by at most a tolerance (mm, part frame; docs/MATH.md §3.7,
§15.4). The depth is `checker.mesh.depth`'s, one body per pose; the sizes bisect together."""

from __future__ import annotations

import math

import numpy as np

from checker.mesh.bvh import MeshIndex
from checker.mesh.core import Tools
from checker.mesh.depth import depths_of_tools
from checker.mesh.inputs import contiguous, rows_of_three, unit_rows
from checker.mesh.pose import Poses
from checker.mesh.tool import BODY, body_profiles, body_top


def _bodies(cutter, sizes: np.ndarray) -> Tools:
    """One tool per size: the body of `cutter.with_size(sizes[i])`, asked of the cutter (its
    cores at those sizes, `Cutter.cores`, and the body's top)."""
    prof, nprof, rho = body_profiles(cutter.cores(sizes), body_top(cutter))
    n = len(sizes)
    return Tools(prof, nprof, contiguous(rho, np.float64), np.full(n, BODY, dtype=np.int64),
                 np.arange(n + 1, dtype=np.int64))


def body_depths(mesh_index: MeshIndex, cutter, sizes: np.ndarray, tips: np.ndarray,
                axes: np.ndarray, *, floor: float) -> np.ndarray:
    """(N,) signed depth of the body of `cutter.with_size(sizes[i])` at pose i, values at or
    below `floor` (mm) reported as `floor` (only triangles beating it are examined)."""
    sizes = contiguous(sizes, np.float64)
    n = len(sizes)
    poses = Poses(contiguous(tips, np.float64), contiguous(axes, np.float64),
                  np.arange(n, dtype=np.int64))
    got, _ = depths_of_tools(mesh_index, _bodies(cutter, sizes), poses, float(floor),
                             max(0.0, -float(floor)))
    return got.depth


def allowable_on_mesh(mesh_index: MeshIndex, cutter, cc: np.ndarray, normals: np.ndarray,
                      axes: np.ndarray, *, tol: float, s_max: float,
                      s_tol: float = 1e-6) -> np.ndarray:
    """(N,) the largest size s in [0, s_max] (mm; the cutter's allowable variable, `cutter.size`)
    such that the body of `cutter.with_size(s)` touching `cc (N, 3)` with unit normal
    `normals (N, 3)` at axis `axes (N, 3)` or `(3,)` (part frame) penetrates the mesh by at most
    `tol` mm (use tol > 0: the contact itself is a depth of 0 up to rounding); inf where s_max
    is still safe, 0 where even s = 0 is not. All rows bisect together to `s_tol` mm; the value
    returned is safe. Where the depth is not monotone in s, one transition is found."""
    cc = rows_of_three(cc, "cc")
    n = len(cc)
    normals = rows_of_three(normals, "normals", n)
    normals = normals / np.linalg.norm(normals, axis=1)[:, None]
    axes = unit_rows(rows_of_three(axes, "axes", n))
    tol, s_max = float(tol), float(s_max)
    if not (s_max > 0.0 and math.isfinite(s_max)):
        raise ValueError("s_max must be a finite number > 0")
    if n == 0:
        return np.zeros(0)

    def unsafe(s: np.ndarray) -> np.ndarray:
        tips = cutter.tip_from_contact(cc, normals, axes, sizes=s)
        return body_depths(mesh_index, cutter, s, tips, axes, floor=tol) > tol

    lo = np.zeros(n)
    hi = np.full(n, s_max)
    top_safe = ~unsafe(hi)
    zero_bad = unsafe(lo)
    while float(np.max(hi - lo)) > s_tol:
        mid = 0.5 * (lo + hi)
        u = unsafe(mid)
        hi = np.where(u, mid, hi)
        lo = np.where(u, lo, mid)
    return np.where(top_safe, np.inf, np.where(zero_bad, 0.0, lo))
