"""The projected Newton step in a surface's parameters (u, v) that every parameter search of the
project takes: foot points of points near a surface (inverse.py), the cutter's contact with the
part (contact.py), points brought onto a flat cutter's bottom plane (engine/refine/objective.py).

For an objective with gradient g = (g_u, g_v) and a symmetric positive semi-definite matrix H
(a positive-definite Hessian, or the Gauss-Newton matrix J^T J of a residual), the step d
minimises g.d + d^T H d / 2: d = -H^-1 g, or where H has rank one (a single residual, e.g. a
height brought to a level: H = a a^T) the least-norm step d = -H^+ g with H^+ = H / trace(H)^2.
A parameter on a bound of its domain whose step would leave it (and that does not wrap around,
as on a closed surface's seam) is held, and the other takes its one-dimensional step -g_k / H_kk
(an active-set step). Parameters in the surface's own units.
(docs/MATH.md §6.1)
"""

from __future__ import annotations

import numba as nb
import numpy as np

_SINGULAR = 1e-12  # relative determinant below which H counts as rank one
_FLAT = 1e-24  # H (mm^2 per parameter^2) no larger than this is zero: no step


@nb.njit(cache=True)
def newton_step(gu, gv, huu, huv, hvv, u, v, lo_u, hi_u, lo_v, hi_v, wraps_u, wraps_v):
    """The projected Newton step (du, dv) at (u, v) in [lo_u, hi_u] x [lo_v, hi_v] (module
    docstring); (0, 0) where H is zero or both parameters are held."""
    trace = huu + hvv
    if not trace > _FLAT:
        return 0.0, 0.0
    det = huu * hvv - huv * huv
    if det > _SINGULAR * trace * trace:
        du = -(hvv * gu - huv * gv) / det
        dv = -(huu * gv - huv * gu) / det
    else:
        k = 1.0 / (trace * trace)
        du = -(huu * gu + huv * gv) * k
        dv = -(huv * gu + hvv * gv) * k
    held_u = not wraps_u and ((u <= lo_u and du < 0.0) or (u >= hi_u and du > 0.0))
    held_v = not wraps_v and ((v <= lo_v and dv < 0.0) or (v >= hi_v and dv > 0.0))
    if held_u and held_v:
        return 0.0, 0.0
    if held_u:
        return 0.0, (-gv / hvv if hvv > _FLAT else 0.0)
    if held_v:
        return (-gu / huu if huu > _FLAT else 0.0), 0.0
    return du, dv


@nb.njit(cache=True)
def _steps(g, H, uv, lo, hi, wraps, out):
    for k in range(g.shape[0]):
        out[k, 0], out[k, 1] = newton_step(
            g[k, 0], g[k, 1], H[k, 0, 0], H[k, 0, 1], H[k, 1, 1], uv[k, 0], uv[k, 1],
            lo[k, 0], hi[k, 0], lo[k, 1], hi[k, 1], wraps[k, 0], wraps[k, 1])


def newton_steps(g: np.ndarray, H: np.ndarray, uv: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 wraps: np.ndarray | None = None) -> np.ndarray:
    """`newton_step` for K rows: gradients `g (K, 2)`, matrices `H (K, 2, 2)`, parameters
    `uv (K, 2)` in [lo, hi] (K, 2), `wraps (K, 2)` the directions that close on themselves
    (default none); the steps (K, 2)."""
    k = len(g)
    wraps = np.zeros((k, 2), dtype=np.bool_) if wraps is None else wraps
    out = np.empty((k, 2))
    if k:
        as_f = [np.ascontiguousarray(a, dtype=np.float64) for a in (g, H, uv, lo, hi)]
        _steps(*as_f, np.ascontiguousarray(wraps, dtype=np.bool_), out)
    return out
