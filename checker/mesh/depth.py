"""Exact penetration depth of a real tool (a union of pieces, `checker.mesh.tool`) into a triangle
mesh (`checker.mesh.bvh.MeshIndex`), at many poses at once (docs/MATH.md §8).

Definitions (tool frame: tip at the origin, axis +z; r radial distance, h height, mm). A piece is
P = K (+) rho B, K the solid of revolution of a convex half-profile polygon (`checker.mesh.core`).
For a set S of triangles the signed value is `signed = -(signed distance between P and S)`: the
penetration depth max over x in S of dist(x, boundary of P) when S meets P, else minus the
clearance dist(S, P). Per triangle T: signed = rho - min over x in T of sd_K(x), sd_K the signed
distance to the core K (negative inside: minus the distance to K's boundary), computed by a
one-dimensional convex minimisation over T's slices (`checker.mesh.slice_depth`). Per pose the
result is the maximum over the pieces and the triangles, by branch and bound
(`checker.mesh.pose`).

The depth is measured against the triangles (the mesh's surface), not the solid they enclose: a
tool entirely inside a closed mesh reports its clearance to the surface."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from checker.mesh.bvh import MeshIndex, Tree
from checker.mesh.candidates import new_candidates
from checker.mesh.core import Tools
from checker.mesh.inputs import one_tool, plain, rows_of_three, unit_rows
from checker.mesh.pose import Effort, PoseDepths, Poses, pose_depth, pose_scratch
from checker.mesh.tool import ToolPieces

__all__ = ["PoseDepths", "depths_of_tools", "pose_depths"]


@nb.njit(cache=True, parallel=True)
def _poses(tree, tools, poses, floor, reach, nchunks):
    """Every pose of `poses` (`pose.pose_depth`), in `nchunks` parallel chunks: (PoseDepths,
    Effort). `tree`, `tools`, `poses`: the fields of a `bvh.Tree`, `core.Tools`, `pose.Poses`
    as plain tuples (`inputs.plain`)."""
    tree, tools, poses = Tree(*tree), Tools(*tools), Poses(*poses)
    n = poses.tip.shape[0]
    out = PoseDepths(np.empty(n), np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64),
                     np.empty((n, 3)))
    effort = Effort(np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
                    np.zeros(n, dtype=np.int64))
    for c in nb.prange(nchunks):
        i0 = c * n // nchunks
        i1 = (c + 1) * n // nchunks
        found = np.empty(256, dtype=np.int64)
        cands = new_candidates(256)
        scratch = pose_scratch()
        for i in range(i0, i1):
            found, cands = pose_depth(i, tree, tools, poses, floor, reach, out, effort, found,
                                      cands, scratch)
    return out, effort


def depths_of_tools(mesh_index: MeshIndex, tools: Tools, poses: Poses, floor: float,
                    reach: float) -> tuple[PoseDepths, Effort]:
    """The signed depth at each of `poses` of its tool of `tools` into the mesh, values at or
    below `floor` (mm) reported as `floor`, clearances computed up to `reach` (mm); and the
    effort per pose. Arrays as the kernels take them (`checker.mesh.inputs`)."""
    n = len(poses.tip)
    nchunks = max(1, min(n, 8 * nb.get_num_threads(), (n + 63) // 64))
    return _poses(*plain(mesh_index.tree(), tools, poses), float(floor), float(reach), nchunks)


def pose_depths(mesh_index: MeshIndex, pieces: ToolPieces, tips: np.ndarray, axes: np.ndarray,
                *, reach: float) -> PoseDepths:
    """Signed penetration depth of the tool `pieces` into the mesh at N poses: `tips (N, 3)`
    (mm, part frame) and `axes (N, 3)` or `(3,)` (tip -> spindle, normalised here). `reach`
    (mm, >= 0): clearances are computed up to it; beyond, the depth is -reach. See
    `PoseDepths`."""
    tips = rows_of_three(tips, "tips")
    axes = unit_rows(rows_of_three(axes, "axes", len(tips)))
    reach = float(reach)
    if not (reach >= 0.0 and math.isfinite(reach)):
        raise ValueError("reach must be a finite number >= 0")
    n = len(tips)
    if n == 0:
        return PoseDepths(np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64),
                          np.zeros((0, 3)))
    poses = Poses(tips, axes, np.zeros(n, dtype=np.int64))
    return depths_of_tools(mesh_index, one_tool(pieces), poses, -reach, reach)[0]
