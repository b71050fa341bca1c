"""Seeds on the bottom-plane contour for flat-bottomed cutters (R family, psi = 0).

Nothing below the bottom plane is cut, and just above it the imaginary size rises steeply, so
the minimum often lies on the contour line where the part crosses that plane, between samples.
Every edge of the sample graph (a test point and one of its nearest test points on the same
surface) that straddles the plane gives a crossing point by linear interpolation; the best few
crossings per row (by their size) start the local refinement, which then follows the exact
contour (refine.py). Tool frame, mm."""

from __future__ import annotations

import numba as nb
import numpy as np

from checker import kernels
from checker.engine.candidates import SERIAL_ROWS
from checker.engine.frames import identity_rows, rotated


@nb.njit(cache=True)
def _crossings_row(i, indptr, indices, xyz, rot, knn, floor, cc, n, e, prm, m, sep, out_p, out_q,
                   out_f, out_v, out_x):
    """Crossings of row i (grid points seen in the row's frame: rot[i] @ p)."""
    for k in range(indptr[i], indptr[i + 1]):
        p = indices[k]
        xp, yp, zp = rotated(rot, i, xyz, p)
        if zp < floor[i]:
            continue
        for t in range(knn.shape[1]):
            q = knn[p, t]
            if q < 0:
                continue
            xq, yq, zq = rotated(rot, i, xyz, q)
            if zq >= floor[i]:
                continue
            f = (zp - floor[i]) / (zp - zq)
            x = xp + f * (xq - xp)
            y = yp + f * (yq - yp)
            v = kernels.apt_size(x - cc[i, 0], y - cc[i, 1], floor[i] + 1e-9 - cc[i, 2],
                                 n[i, 0], n[i, 1], n[i, 2], e[i, 0], e[i, 1], True, prm)
            if not v < np.inf:
                continue
            slot = -1  # the seed of the same place, else the worst seed
            for s in range(m):
                dx, dy = out_x[i, s, 0] - x, out_x[i, s, 1] - y
                if out_p[i, s] >= 0 and dx * dx + dy * dy < sep * sep:
                    slot = s
                    break
            if slot < 0:
                slot = 0
                for s in range(1, m):
                    if out_v[i, s] > out_v[i, slot]:
                        slot = s
            if v < out_v[i, slot]:
                out_v[i, slot], out_p[i, slot], out_q[i, slot], out_f[i, slot] = v, p, q, f
                out_x[i, slot, 0], out_x[i, slot, 1] = x, y


@nb.njit(cache=True, parallel=True)
def _crossings_par(indptr, indices, xyz, rot, knn, floor, cc, n, e, prm, m, sep, out_p, out_q,
                   out_f, out_v, out_x):
    for i in nb.prange(indptr.shape[0] - 1):
        _crossings_row(i, indptr, indices, xyz, rot, knn, floor, cc, n, e, prm, m, sep, out_p,
                       out_q, out_f, out_v, out_x)


@nb.njit(cache=True)
def _crossings_ser(indptr, indices, xyz, rot, knn, floor, cc, n, e, prm, m, sep, out_p, out_q,
                   out_f, out_v, out_x):
    for i in range(indptr.shape[0] - 1):
        _crossings_row(i, indptr, indices, xyz, rot, knn, floor, cc, n, e, prm, m, sep, out_p,
                       out_q, out_f, out_v, out_x)


def contour_seeds(cutter, cc, n, e, floor, xyz, knn, indptr, indices, m: int, sep: float,
                  rot: np.ndarray | None = None):
    """Per row (N) up to m crossings at least `sep` mm apart (the best of each place): (row
    (S,), p (S,), q (S,), fraction (S,), size (S,)) with
    the crossing at `xyz[p] + fraction * (xyz[q] - xyz[p])`; rows `cc`, `n`, `e` (N, 3) and
    bottom heights `floor (N,)` in the tool frame, candidates in CSR over `xyz`; `rot (N, 3, 3)`
    each row's tool frame seen from the frame of `xyz` (row i sees `rot[i] @ xyz[p]`; default:
    the same frame)."""
    rows = len(floor)
    out_p = np.full((rows, m), -1, dtype=np.int64)
    out_q = np.full((rows, m), -1, dtype=np.int64)
    out_f = np.zeros((rows, m))
    out_v = np.full((rows, m), np.inf)
    out_x = np.zeros((rows, m, 2))
    rot = identity_rows(rows) if rot is None else np.ascontiguousarray(rot)
    kernel = _crossings_ser if rows < SERIAL_ROWS else _crossings_par
    kernel(indptr, indices, xyz, rot, knn, floor, cc, n, e, cutter.kernel_params(), m, sep, out_p,
           out_q, out_f, out_v, out_x)
    r, c = np.nonzero(np.isfinite(out_v))
    return r, out_p[r, c], out_q[r, c], out_f[r, c], out_v[r, c]
