"""Certify a stretch of a move at once: no pose along it goes deeper into the mesh than a
tolerance, however long the stretch (`checker.verify.along_moves` asks this before halving).

Reference motion: the tool at the stretch's middle orientation (axis a, tool frame as in
`checker.mesh.tool_frame`) translating along the chord of the tips, tip c + s w, s in [-1/2, 1/2].
The real pose at s differs from the reference by a rigid motion that moves a point x (tool
frame, measured from the reference tip) by at most tau + alpha |x| (tau: how far the real tip
leaves the chord; alpha: the largest angle between the real axis and a; both bounded by the
caller), so its signed value against the real tool is at most the reference's plus
slack = tau (1 + alpha) + alpha |x| (a signed distance is 1-Lipschitz), taken at a prism's
farthest vertex but never beyond `far` (the core's reach from the tip plus rho, the stretch
and 1 mm): a point beyond it is farther from the core than its slack can make up, so a large
triangle is not charged for its far corners.

Under the translation a triangle T meets the piece P = K (+) rho B as T (-) s w meets the piece
at rest: over the whole reference motion T's largest signed value is that of the prism
T (+) [-w/2, w/2] (convex, six vertices), rho - min over the prism of sd_K. It is at most
tol - slack when dist(prism, K) >= rho - tol + slack (GJK on the prism's vertices; where that
is not positive, the prism must miss the core eroded by tol - slack - rho). Every candidate
triangle of every piece passing certifies the stretch; one failing leaves it to be halved.
Exact for a pure translation (alpha = tau = 0): a ball sliding on a plane is certified in one
test, where the depth bound of `checker.verify` needs stretches of twice the tolerance.
(docs/MATH.md §8.1)"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np

from checker.mesh.bounds import quick_upper
from checker.mesh.bvh import STACK, MeshIndex, Tree, query_capsule
from checker.mesh.core import PROFILE_ROWS, Tools, core_buffers, eroded, piece_core
from checker.mesh.gjk import FARTHER, SEPARATED, Simplex, gjk_distance, simplex_buffers
from checker.mesh.inputs import contiguous, one_tool, plain
from checker.mesh.tool import ToolPieces
from checker.mesh.tool_frame import (
    along_axis,
    box_top,
    direction_in_tool,
    tool_frame,
    triangle_in_tool,
)

TOO_TURNED = 0.25  # mm: a slack this large anywhere near a piece is not worth a test


class Stretches(NamedTuple):
    """S stretches' reference motions (mm, part frame): tips `mid (S, 3)` + sigma `half (S, 3)`,
    sigma in [-1, 1], at unit axes `axis (S, 3)`; how far the real poses leave them, `tau (S,)`
    mm and `alpha (S,)` radians; the tolerance `tol (S,)` mm each must be certified within."""

    mid: np.ndarray
    axis: np.ndarray
    half: np.ndarray
    tau: np.ndarray
    alpha: np.ndarray
    tol: np.ndarray


class _Scratch(NamedTuple):
    """One thread's buffers: the tree's traversal `stack`, the core's `profile`, `normal`,
    `offset`, the `prism (6, 3)`, GJK's `simplex` and the erosion's buffers `eroded_a`,
    `eroded_b` (PROFILE_ROWS, 2)."""

    stack: np.ndarray
    profile: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    prism: np.ndarray
    simplex: Simplex
    eroded_a: np.ndarray
    eroded_b: np.ndarray


@nb.njit(cache=True)
def _scratch():
    """A new `_Scratch`."""
    profile, normal, offset = core_buffers()
    return _Scratch(np.empty(STACK, dtype=np.int64), profile, normal, offset, np.empty((6, 3)),
                    simplex_buffers(), np.empty((PROFILE_ROWS, 2)), np.empty((PROFILE_ROWS, 2)))


@nb.njit(cache=True)
def _prism_passes(V, core, tol, tau, alpha, far, scratch):
    """Whether the prism V (6, 3) (tool frame) stays within `tol` of the piece (`core.Core`)
    with the slack of the turning at its farthest vertex, or at `far` (mm from the tip) if that
    is nearer: beyond it no point can reach the piece."""
    r2 = 0.0
    for k in range(V.shape[0]):
        r2 = max(r2, V[k, 0] ** 2 + V[k, 1] ** 2 + V[k, 2] ** 2)
    slack = tau * (1.0 + alpha) + alpha * min(math.sqrt(r2), far) + 1e-9
    if quick_upper(V, core) + slack <= tol:
        return True
    thresh = core.rho - tol + slack  # dist(prism, K) must reach this
    start = (V[0, 0], V[0, 1], V[0, 2])
    if thresh > 0.0:
        P = core.profile
        got = gjk_distance(V, P, core.count, thresh, start, (P[0, 0], 0.0, P[0, 1]),
                           scratch.simplex)
        return got.status == FARTHER or (got.status == SEPARATED and got.lower >= thresh)
    if not core.solid:  # a segment core: sd_K >= 0, every value at most rho
        return True
    Q, mq = eroded(core, -thresh, scratch.eroded_a, scratch.eroded_b)
    if mq == 0:
        return True
    got = gjk_distance(V, Q, mq, 0.0, start, (Q[0, 0], 0.0, Q[0, 1]), scratch.simplex)
    return got.status == FARTHER


@nb.njit(cache=True)
def _stretch(i, tree, tools, stretches, found, scratch):
    """Whether stretch i is certified (module docstring). Returns (passed, found)."""
    f = tool_frame((stretches.mid[i, 0], stretches.mid[i, 1], stretches.mid[i, 2]),
                   (stretches.axis[i, 0], stretches.axis[i, 1], stretches.axis[i, 2]))
    half = (stretches.half[i, 0], stretches.half[i, 1], stretches.half[i, 2])
    wx, wy, wz = direction_in_tool(f, half)
    hx, hy, hz = half
    hn = math.sqrt(hx * hx + hy * hy + hz * hz)
    hm = box_top(tree.lo, tree.hi, f) + hn  # above any pose of the stretch
    tol, tau, alpha = stretches.tol[i], stretches.tau[i], stretches.alpha[i]
    V = scratch.prism
    for p in range(tools.first[0], tools.first[1]):
        rp = tools.rho[p]
        core = piece_core(tools, p, hm + rp + 1.0, scratch.profile, scratch.normal,
                          scratch.offset)
        if core.count == 0:
            continue
        # a point farther than `far` from the tip is farther from the core than its slack can
        # make up (the core lies within max|h| + rmax of the tip; alpha far <= TOO_TURNED)
        far = max(abs(core.hlo), abs(core.hhi)) + core.rmax + hn + rp + 1.0 + max(0.0, -tol)
        worst = tau * (1.0 + alpha) + alpha * far
        if worst > TOO_TURNED:
            return False, found
        pad = core.rmax + hn + max(rp - tol + worst, 0.0) + 1e-9
        L = core.hhi - core.hlo
        e = f.axis
        found, k_c = query_capsule(tree, along_axis(f, core.hlo), (L * e[0], L * e[1], L * e[2]),
                                   pad, found, scratch.stack)
        for q in range(k_c):
            triangle_in_tool(f, tree.tri_verts, found[q], V)
            for v in range(3):  # the triangle swept back and forth by half the stretch
                x, y, z = V[v, 0], V[v, 1], V[v, 2]
                V[v, 0], V[v, 1], V[v, 2] = x - wx, y - wy, z - wz
                V[v + 3, 0], V[v + 3, 1], V[v + 3, 2] = x + wx, y + wy, z + wz
            if not _prism_passes(V, core, tol, tau, alpha, far, scratch):
                return False, found
    return True, found


@nb.njit(cache=True, parallel=True)
def _stretches(tree, tools, stretches, nchunks):
    """Whether each stretch is certified (`_stretch`), in `nchunks` parallel chunks. `tree`,
    `tools`, `stretches`: the fields of a `bvh.Tree`, `core.Tools`, `Stretches` as plain
    tuples (`inputs.plain`)."""
    tree, tools, stretches = Tree(*tree), Tools(*tools), Stretches(*stretches)
    n = stretches.mid.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    for c in nb.prange(nchunks):
        found = np.empty(256, dtype=np.int64)
        scratch = _scratch()
        for i in range(c * n // nchunks, (c + 1) * n // nchunks):
            out[i], found = _stretch(i, tree, tools, stretches, found, scratch)
    return out


def certified_stretches(mesh_index: MeshIndex, pieces: ToolPieces, mids: np.ndarray,
                        axes: np.ndarray, half: np.ndarray, tau: np.ndarray, alpha: np.ndarray,
                        tol: np.ndarray) -> np.ndarray:
    """(S,) bool: stretch s certified within `tol[s]` mm at every pose (module docstring).
    Reference motion: tips `mids (S, 3)` + sigma `half (S, 3)`, sigma in [-1, 1], unit axes
    `axes (S, 3)` (mm, part frame); `tau (S,)` mm and `alpha (S,)` radians bound how far the
    real poses leave it."""
    n = len(mids)
    if n == 0:
        return np.zeros(0, dtype=bool)
    nchunks = max(1, min(n, 8 * nb.get_num_threads(), (n + 15) // 16))
    f = np.float64
    stretches = Stretches(contiguous(mids, f), contiguous(axes, f), contiguous(half, f),
                          contiguous(tau, f), contiguous(alpha, f), contiguous(tol, f))
    tools: Tools = one_tool(pieces)
    return _stretches(*plain(mesh_index.tree(), tools, stretches), nchunks)
