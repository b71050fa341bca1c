"""The signed depth of a tool in a triangle mesh at one pose, by branch and bound over the tool's
pieces and the triangles near each (docs/MATH.md §8).

For each piece P = K (+) rho B (`checker.mesh.core`) the tree gives the triangles near it (its
axis segment's box grown by the piece's radius plus rho minus the best value so far, i.e. at most
`reach` of clearance); each gets cheap upper bounds (`checker.mesh.bounds`) and the exact value
(`checker.mesh.slice_depth`) is computed only for triangles whose bound beats the best value so
far, in order of that bound, after the value at their point nearest the axis (a lower bound). An
unbounded piece is clipped per pose at a height above the mesh's box that keeps every distance
within `reach` and every depth.

The kernels called per candidate triangle (the frame's transforms, the bounds, the candidates'
rows) allocate nothing and are compiled without numba's reference counting (`_nrt=False`):
with it, each call counted every array of the records it was passed up and down."""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from checker.mesh.bounds import lower_bound, plane_upper, quick_upper, upper_bound
from checker.mesh.bvh import STACK, query_capsule
from checker.mesh.candidates import best_left, keep, new_candidates, take
from checker.mesh.core import core_buffers, piece_core
from checker.mesh.slice_depth import BRACKET_COLUMNS, BRACKETS, SLICE_EPS, exact_value
from checker.mesh.tool_frame import (
    along_axis,
    box_top,
    direction_in_tool,
    point_in_part,
    tool_frame,
    triangle_in_tool,
)

_BEATS = 1e-10  # mm: a kept triangle is examined while its upper bound beats the best by this


class PoseDepths(NamedTuple):
    """Per pose: `depth (N,)` mm (> 0 penetration depth, < 0 clearance, -reach when nothing is
    within reach), `piece (N,)` kind of the deepest piece (0 body, 1 shank, 2 holder; -1 when
    depth <= 0), `triangle (N,)` index of the deepest (or nearest) triangle (-1 when nothing is
    within reach), `point (N, 3)` the deepest (or nearest) point of the mesh on it, mm, part frame
    (nan when nothing is within reach)."""

    depth: np.ndarray
    piece: np.ndarray
    triangle: np.ndarray
    point: np.ndarray


class Poses(NamedTuple):
    """N poses (mm, part frame): `tip (N, 3)`, unit `axis (N, 3)` (tip -> spindle) and the
    `tool (N,)` of each (its index in `core.Tools`)."""

    tip: np.ndarray
    axis: np.ndarray
    tool: np.ndarray


class Effort(NamedTuple):
    """Per pose, summed over the pieces: triangles the tree gave (`candidates`), kept after the
    cheap bounds (`kept`) and evaluated exactly (`exact`)."""

    candidates: np.ndarray
    kept: np.ndarray
    exact: np.ndarray


class PoseScratch(NamedTuple):
    """One thread's buffers: the tree's traversal `stack (STACK,)`, the core's `profile`,
    `normal` and `offset` (`core.core_buffers`), a `triangle (3, 3)` and the slice
    minimisation's `brackets`."""

    stack: np.ndarray
    profile: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    triangle: np.ndarray
    brackets: np.ndarray


@nb.njit(cache=True)
def pose_scratch():
    """A new `PoseScratch`."""
    profile, normal, offset = core_buffers()
    return PoseScratch(np.empty(STACK, dtype=np.int64), profile, normal, offset,
                       np.empty((3, 3)), np.empty((BRACKETS, BRACKET_COLUMNS)))


@nb.njit(cache=True)
def pose_depth(i, tree, tools, poses, floor, reach, out, effort, found, cands, scratch):
    """Pose i of `poses` against the mesh `tree` (`bvh.Tree`): its row of `out` (`PoseDepths`;
    values at or below `floor` mm reported as `floor`) and of `effort`. `found` (the tree's
    answer) and `cands` (`Candidates`) are buffers, returned grown when needed."""
    f = tool_frame((poses.tip[i, 0], poses.tip[i, 1], poses.tip[i, 2]),
                   (poses.axis[i, 0], poses.axis[i, 1], poses.axis[i, 2]))
    best = floor
    best_tri = -1
    best_piece = -1
    bx = by = bz = np.nan
    hm = box_top(tree.lo, tree.hi, f)
    T = scratch.triangle
    tool = poses.tool[i]
    for p in range(tools.first[tool], tools.first[tool + 1]):
        rp = tools.rho[p]
        # an unbounded piece clipped above the mesh, with room for distances within reach
        core = piece_core(tools, p, hm + rp + max(reach, 0.0) + 1.0, scratch.profile,
                          scratch.normal, scratch.offset)
        if core.count == 0:
            continue
        pad = core.rmax + max(rp - best, 0.0) + 1e-9
        L = core.hhi - core.hlo
        e = f.axis
        found, k_c = query_capsule(tree, along_axis(f, core.hlo), (L * e[0], L * e[1], L * e[2]),
                                   pad, found, scratch.stack)
        effort.candidates[i] += k_c
        if k_c == 0:
            continue
        if cands.upper.shape[0] < k_c:
            cands = new_candidates(found.shape[0])
        nkeep = 0
        for q in range(k_c):
            t = found[q]
            triangle_in_tool(f, tree.tri_verts, t, T)
            n = direction_in_tool(f, (tree.tri_normal[t, 0], tree.tri_normal[t, 1],
                                      tree.tri_normal[t, 2]))
            up = min(quick_upper(T, core), plane_upper(T, n, core))
            if up <= best:
                continue
            bound = upper_bound(T, core)
            upper = min(bound.upper, up)
            if upper <= best:
                continue
            keep(cands, nkeep, t, upper, bound.point, T)
            nkeep += 1
        effort.kept[i] += nkeep
        # best first by upper bound: select the largest left (few are examined)
        nleft = nkeep
        while nleft > 0:
            jb = best_left(cands, nleft)
            ub = cands.upper[jb]
            if ub <= best + _BEATS:
                break
            nleft -= 1
            t, point = take(cands, jb, nleft, T)
            low = lower_bound(core, ub, point)
            if low > best:
                best = low
                best_tri = tree.tri_id[t]
                best_piece = tools.kind[p]
                bx, by, bz = point_in_part(f, point[0], point[1], point[2])
            if ub <= best + SLICE_EPS:
                continue
            effort.exact[i] += 1
            val, at = exact_value(T, core, best, scratch.brackets)
            if val > best:
                best = val
                best_tri = tree.tri_id[t]
                best_piece = tools.kind[p]
                bx, by, bz = point_in_part(f, at[0], at[1], at[2])
    out.depth[i] = best
    out.piece[i] = best_piece if best > 0.0 else -1
    out.triangle[i] = best_tri
    out.point[i, 0], out.point[i, 1], out.point[i, 2] = bx, by, bz
    return found, cands
