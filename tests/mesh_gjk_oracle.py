"""An independent oracle of the exact mesh depth (`checker.mesh.pose_depths`), for tests only:
each triangle's signed value against a piece P = K (+) rho B by GJK (`checker.mesh.gjk`) instead
of the product's one-dimensional slice minimisation; with `prune=False` every triangle the tree
gives is examined (no upper bounds), which checks the branch and bound's pruning too.

Per triangle T: dist(T, K) by GJK; where T meets K, the erosion depth t* = sup{t : T meets
K (-) tB} is bracketed with GJK on the eroded cores (an intersection at t gives t* >= t; a
separation by d at t gives t - d <= t* < t since K_t (+) dB lies in K_(t-d)), shrunk by that
lower bound, secant steps and bisection to EPS_T; the value is rho + t*. Near a contact with a
curved rim GJK converges slowly and may not certify a separation; it then keeps the upper end of
its bracket, so it can over-state a depth by ~1e-6 mm, never under-state it."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from checker.mesh.bounds import lower_bound, plane_upper, quick_upper, upper_bound
from checker.mesh.bvh import STACK, MeshIndex, query_capsule
from checker.mesh.core import (
    PROFILE_ROWS,
    core_buffers,
    eroded,
    lift,
    piece_core,
    signed_distance,
)
from checker.mesh.gjk import (
    FARTHER,
    SEPARATED,
    TOUCHING,
    UNCERTIFIED,
    gjk_distance,
    simplex_buffers,
)
from checker.mesh.inputs import one_tool, rows_of_three, unit_rows
from checker.mesh.pose import PoseDepths
from checker.mesh.tool import ToolPieces
from checker.mesh.tool_frame import (
    along_axis,
    box_top,
    direction_in_tool,
    point_in_part,
    tool_frame,
    triangle_in_tool,
)

EPS_T = 1e-10  # mm: width of the final bracket on the erosion depth t*


@nb.njit(cache=True)
def _centroid(T):
    return ((T[0, 0] + T[1, 0] + T[2, 0]) / 3.0, (T[0, 1] + T[1, 1] + T[2, 1]) / 3.0,
            (T[0, 2] + T[1, 2] + T[2, 2]) / 3.0)


@nb.njit(cache=True)
def _gjk_value(T, core, best, low, start, hi, simplex, buf_a, buf_b):
    """Signed value of triangle T (tool frame) against the piece if it beats `best` (mm), else
    -inf; and T's point of that value. Known: a lower bound `low` of the value (-inf: none), a
    point `start` of T and an upper bound `hi` of t*."""
    rho = core.rho
    need = best - rho                  # t* must exceed this
    lo = -np.inf                       # t* >= lo, with a point of T at that depth (wit)
    if low - rho >= 0.0:
        lo = low - rho
    wit = start
    if need < 0.0 and lo < 0.0:
        # is T within reach of K at all? GJK from the start point
        _, qr, qh = signed_distance(core, core.profile, core.count, 0.0,
                                    math.sqrt(wit[0] ** 2 + wit[1] ** 2), wit[2])
        got = gjk_distance(T, core.profile, core.count, -need, wit,
                           lift(wit[0], wit[1], qr, qh), simplex)
        if got.status == FARTHER:
            return -np.inf, wit
        if got.status == SEPARATED:
            val = rho - got.lower
            if val > best:
                return val, got.point
            return -np.inf, wit
        lo = 0.0            # touching, or not certified (within `upper`): taken as touching
        wit = got.point
    if not core.solid:
        if lo >= 0.0 and rho > best:
            return rho, wit
        return -np.inf, wit
    # bracket [lo, hi] on t*; separated probes (t, d) for the secant
    t1 = d1 = t2 = d2 = 0.0
    npairs = 0
    bisect = False
    first = True
    for _ in range(200):
        if hi <= need + EPS_T or hi <= lo:
            if hi <= need + EPS_T:
                return -np.inf, wit
            break
        if lo > need and hi - lo <= EPS_T:
            break
        if lo <= need:
            tp = max(need, lo) + 0.5 * EPS_T       # does T beat the best at all?
        elif first:
            tp = hi
        elif bisect or npairs == 0:
            tp = 0.5 * (lo + hi)
        elif npairs == 1:
            tp = t2 - d2 + 0.5 * EPS_T
        else:
            tp = t2 - d2 * (t2 - t1) / (d2 - d1) + 0.5 * EPS_T if d2 != d1 else 0.5 * (lo + hi)
        if not (tp > lo and tp <= hi):
            tp = 0.5 * (lo + hi)
        first = False
        width = hi - lo
        Q, mq = eroded(core, tp, buf_a, buf_b)
        if mq == 0:
            hi = tp
            bisect = True
            continue
        sd, qr, qh = signed_distance(core, Q, mq, tp, math.sqrt(wit[0] ** 2 + wit[1] ** 2),
                                     wit[2])
        if sd <= 0.0:
            lo = tp
            bisect = hi - lo > 0.5 * width
            continue
        got = gjk_distance(T, Q, mq, np.inf, wit, lift(wit[0], wit[1], qr, qh), simplex)
        if got.status == TOUCHING:
            lo = tp
            wit = got.point
        elif got.status == UNCERTIFIED:
            if tp - got.upper > lo:        # not certified: only the lower bound
                lo = tp - got.upper
                wit = got.point
        else:
            hi = tp
            d = got.upper
            if tp - d > lo:
                lo = tp - d
                wit = got.point
            t1, d1 = t2, d2
            t2, d2 = tp, d
            npairs += 1
        bisect = hi - lo > 0.5 * width
    if lo <= need:
        return -np.inf, wit
    return rho + hi, wit


@nb.njit(cache=True)
def _pruned(tree, f, found, k, core, kind, best, best_tri, best_piece, bx, by, bz, T, simplex,
            buf_a, buf_b):
    """The product's branch and bound over one piece's `k` candidates `found` (its bounds,
    `checker.mesh.bounds`, best upper bound first) with GJK for the exact values: the best
    (value, triangle, piece, point) after them."""
    upper = np.empty(k)
    for q in range(k):
        triangle_in_tool(f, tree.tri_verts, found[q], T)
        t = found[q]
        n = direction_in_tool(f, (tree.tri_normal[t, 0], tree.tri_normal[t, 1],
                                  tree.tri_normal[t, 2]))
        upper[q] = min(quick_upper(T, core), plane_upper(T, n, core))
    for q in np.argsort(-upper):
        if upper[q] <= best + EPS_T:
            break
        triangle_in_tool(f, tree.tri_verts, found[q], T)
        bound = upper_bound(T, core)
        ub = min(bound.upper, upper[q])
        if ub <= best + EPS_T:
            continue
        low = lower_bound(core, ub, bound.point)
        if low > best:
            best, best_tri, best_piece = low, tree.tri_id[found[q]], kind
            bx, by, bz = point_in_part(f, bound.point[0], bound.point[1], bound.point[2])
        if ub <= best + EPS_T:
            continue
        val, at = _gjk_value(T, core, best, low, bound.point, bound.erosion, simplex, buf_a,
                             buf_b)
        if val > best:
            best, best_tri, best_piece = val, tree.tri_id[found[q]], kind
            bx, by, bz = point_in_part(f, at[0], at[1], at[2])
    return best, best_tri, best_piece, bx, by, bz


@nb.njit(cache=True, parallel=True)
def _poses(tree, tools, tips, axes, floor, reach, prune):
    n = tips.shape[0]
    depth, piece = np.empty(n), np.empty(n, dtype=np.int64)
    triangle, point = np.empty(n, dtype=np.int64), np.empty((n, 3))
    for i in nb.prange(n):
        found = np.empty(256, dtype=np.int64)
        stack = np.empty(STACK, dtype=np.int64)
        profile, normal, offset = core_buffers()
        simplex = simplex_buffers()
        buf_a, buf_b = np.empty((PROFILE_ROWS, 2)), np.empty((PROFILE_ROWS, 2))
        T = np.empty((3, 3))
        f = tool_frame((tips[i, 0], tips[i, 1], tips[i, 2]), (axes[i, 0], axes[i, 1], axes[i, 2]))
        best, best_tri, best_piece = floor, -1, -1
        bx = by = bz = np.nan
        hm = box_top(tree.lo, tree.hi, f)
        for p in range(tools.first[0], tools.first[1]):
            core = piece_core(tools, p, hm + tools.rho[p] + reach + 1.0, profile, normal, offset)
            if core.count == 0:
                continue
            pad = core.rmax + max(core.rho - best, 0.0) + 1e-9
            L = core.hhi - core.hlo
            e = f.axis
            found, k = query_capsule(tree, along_axis(f, core.hlo),
                                     (L * e[0], L * e[1], L * e[2]), pad, found, stack)
            if prune:
                best, best_tri, best_piece, bx, by, bz = _pruned(
                    tree, f, found, k, core, tools.kind[p], best, best_tri, best_piece, bx, by,
                    bz, T, simplex, buf_a, buf_b)
                continue
            # every triangle, deepest centroid first (a lower bound of each one's value), so
            # that the best rises early and most are turned down by one GJK call
            low = np.empty(k)
            for q in range(k):
                triangle_in_tool(f, tree.tri_verts, found[q], T)
                c = _centroid(T)
                sd, _, _ = signed_distance(core, core.profile, core.count, 0.0,
                                           math.sqrt(c[0] ** 2 + c[1] ** 2), c[2])
                low[q] = core.rho - sd
            for q in np.argsort(-low):
                triangle_in_tool(f, tree.tri_verts, found[q], T)
                val, at = _gjk_value(T, core, best, -np.inf, _centroid(T),
                                     core.rmax + (core.hhi - core.hlo), simplex, buf_a, buf_b)
                if val > best:
                    best, best_tri, best_piece = val, tree.tri_id[found[q]], tools.kind[p]
                    bx, by, bz = point_in_part(f, at[0], at[1], at[2])
        depth[i] = best
        piece[i] = best_piece if best > 0.0 else -1
        triangle[i] = best_tri
        point[i, 0], point[i, 1], point[i, 2] = bx, by, bz
    return PoseDepths(depth, piece, triangle, point)


def gjk_pose_depths(mesh_index: MeshIndex, pieces: ToolPieces, tips: np.ndarray,
                    axes: np.ndarray, *, reach: float, prune: bool = True) -> PoseDepths:
    """`checker.mesh.pose_depths` (same arguments and answer) with GJK for each triangle's
    value; `prune`: the product's bounds and best-first order turn triangles down (else every
    triangle near the tool is evaluated: slower, and a check of the pruning too)."""
    tips = rows_of_three(tips, "tips")
    axes = unit_rows(rows_of_three(axes, "axes", len(tips)))
    return _poses(mesh_index.tree(), one_tool(pieces), tips, axes, -float(reach),
                  float(reach), bool(prune))
