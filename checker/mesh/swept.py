"""Certify a stretch of a move at once: no pose along it goes deeper into the mesh than a
tolerance, however long the stretch (`checker.verify.along_moves` asks this before halving).

Reference motion: the tool at the stretch's middle orientation (axis a, tool frame as in
`checker.mesh.depth`) translating along the chord of the tips, tip c + s w, s in [-1/2, 1/2].
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
test, where the depth bound of `checker.verify` needs stretches of twice the tolerance."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from checker.mesh.bvh import MeshIndex, query_capsule
from checker.mesh.depth import (
    _arr,
    _box_top,
    _erode,
    _frame,
    _gjk,
    _in_tool_frame,
    _piece_core,
    _piece_scratch,
    _quick_upper,
)
from checker.mesh.tool import ToolPieces

TOO_TURNED = 0.25  # mm: a slack this large anywhere near a piece is not worth a test


@nb.njit(cache=True)
def _prism_passes(V, P, m, cn, cc, nc, solid, rho, tol, tau, alpha, far, rmax, hlo, hhi, W,
                  A, lam, res, buf_a, buf_b):
    """Whether the prism V (6, 3) (tool frame) stays within `tol` of the piece (core P[:m],
    its sides cn, cc, grown by rho) with the slack of the turning at its farthest vertex, or
    at `far` (mm from the tip) if that is nearer: beyond it no point can reach the piece."""
    r2 = 0.0
    for k in range(V.shape[0]):
        r2 = max(r2, V[k, 0] ** 2 + V[k, 1] ** 2 + V[k, 2] ** 2)
    slack = tau * (1.0 + alpha) + alpha * min(math.sqrt(r2), far) + 1e-9
    if _quick_upper(V, cn, cc, nc, solid, rho, rmax, hlo, hhi) + slack <= tol:
        return True
    thresh = rho - tol + slack  # dist(prism, K) must reach this
    if thresh > 0.0:
        st = _gjk(V, P, m, thresh, V[0, 0], V[0, 1], V[0, 2], P[0, 0], 0.0, P[0, 1], W, A,
                  lam, res)
        return st == 2 or (st == 0 and res[0] >= thresh)
    if not solid:  # a segment core: sd_K >= 0, every value at most rho
        return True
    Q, mq = _erode(P, m, cn, cc, nc, -thresh, buf_a, buf_b)
    if mq == 0:
        return True
    st = _gjk(V, Q, mq, 0.0, V[0, 0], V[0, 1], V[0, 2], Q[0, 0], 0.0, Q[0, 1], W, A, lam, res)
    return st == 2


@nb.njit(cache=True)
def _stretch(i, node_lo, node_hi, node_left, node_right, node_start, node_count, tv, mlo, mhi,
             prof, nprof, rho, mids, axes, half, tau, alpha, tol, cand, stack, P, Pc, cn, cc,
             V, W, A, lam, res, buf_a, buf_b):
    """Whether stretch i is certified (module docstring). Returns (passed, cand)."""
    px, py, pz = mids[i, 0], mids[i, 1], mids[i, 2]
    e1x, e1y, e1z, e2x, e2y, e2z, ex, ey, ez = _frame(axes[i, 0], axes[i, 1], axes[i, 2])
    hx, hy, hz = half[i, 0], half[i, 1], half[i, 2]
    wx = hx * e1x + hy * e1y + hz * e1z
    wy = hx * e2x + hy * e2y + hz * e2z
    wz = hx * ex + hy * ey + hz * ez
    hn = math.sqrt(hx * hx + hy * hy + hz * hz)
    hm = _box_top(mlo, mhi, px, py, pz, ex, ey, ez) + hn  # above any pose of the stretch
    for p in range(prof.shape[0]):
        rp = rho[p]
        mc, nc, solid, rmax, hlo, hhi = _piece_core(prof, nprof, p, hm + rp + 1.0, P, Pc, cn,
                                                    cc)
        if mc == 0:
            continue
        # a point farther than `far` from the tip is farther from the core than its slack can
        # make up (the core lies within max|h| + rmax of the tip; alpha far <= TOO_TURNED)
        far = max(abs(hlo), abs(hhi)) + rmax + hn + rp + 1.0 + max(0.0, -tol[i])
        worst = tau[i] * (1.0 + alpha[i]) + alpha[i] * far
        if worst > TOO_TURNED:
            return False, cand
        pad = rmax + hn + max(rp - tol[i] + worst, 0.0) + 1e-9
        sx, sy, sz = px + hlo * ex, py + hlo * ey, pz + hlo * ez
        L = hhi - hlo
        cand, k_c = query_capsule(node_lo, node_hi, node_left, node_right, node_start,
                                  node_count, sx, sy, sz, L * ex, L * ey, L * ez, pad, cand,
                                  stack)
        for q in range(k_c):
            t = cand[q]
            _in_tool_frame(tv, t, px, py, pz, e1x, e1y, e1z, e2x, e2y, e2z, ex, ey, ez, V)
            for v in range(3):  # the triangle swept back and forth by half the stretch
                x, y, z = V[v, 0], V[v, 1], V[v, 2]
                V[v, 0], V[v, 1], V[v, 2] = x - wx, y - wy, z - wz
                V[v + 3, 0], V[v + 3, 1], V[v + 3, 2] = x + wx, y + wy, z + wz
            if not _prism_passes(V, Pc, mc, cn, cc, nc, solid, rp, tol[i], tau[i], alpha[i],
                                 far, rmax, hlo, hhi, W, A, lam, res, buf_a, buf_b):
                return False, cand
    return True, cand


@nb.njit(cache=True, parallel=True)
def _stretches(node_lo, node_hi, node_left, node_right, node_start, node_count, tv, mlo, mhi,
               prof, nprof, rho, mids, axes, half, tau, alpha, tol, nchunks):
    n = mids.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    for c in nb.prange(nchunks):
        cand = np.empty(256, dtype=np.int64)
        stack, P, Pc, cn, cc, W, A, lam, res, buf_a, buf_b = _piece_scratch()
        V = np.empty((6, 3))
        for i in range(c * n // nchunks, (c + 1) * n // nchunks):
            out[i], cand = _stretch(i, node_lo, node_hi, node_left, node_right, node_start,
                                    node_count, tv, mlo, mhi, prof, nprof, rho, mids, axes, half,
                                    tau, alpha, tol, cand, stack, P, Pc, cn, cc, V, W, A, lam,
                                    res, buf_a, buf_b)
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
    lo, hi, left, right, start, count, tv, _, _, mlo, mhi = mesh_index.arrays()
    nchunks = max(1, min(n, 8 * nb.get_num_threads(), (n + 15) // 16))
    f = np.float64
    return _stretches(lo, hi, left, right, start, count, tv, mlo, mhi, _arr(pieces.prof, f),
                      _arr(pieces.nprof, np.int64), _arr(pieces.rho, f), _arr(mids, f),
                      _arr(axes, f), _arr(half, f), _arr(tau, f), _arr(alpha, f), _arr(tol, f),
                      nchunks)
