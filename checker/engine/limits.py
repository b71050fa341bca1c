"""The allowable size in the limit P -> Pcc, for flat end-mills (r = 0, psi = 0), in closed form.

A flat end-mill touching at Pcc has its bottom plane through Pcc, so the part's contour line at
that height passes through Pcc, along the horizontal tangent t = z x e (tool frame). On it
dz = 0 and k = 0, so R(P) = |d|^2 / (2 e.d) with d = P_h - Pcc_h. Along the contour
d = s t + s^2/2 kappa + O(s^3), kappa the contour's curvature vector (horizontal, along e), so
R -> 1 / (e.kappa). Meusnier: the surface's normal curvature along t is
k_n(t) = n.kappa = |n_h| (e.kappa), hence

    R_lim = |n_h| / k_n(t),   k_n(t) = n . S''(t, t)   (inf when k_n <= 0),

the infimum over the points of the contour next to Pcc, which no sample and no local step
reaches (the points within the exclusion radius are the CC point). Everywhere else (balls,
bull-noses) the rings of refinement starts around Pcc reach the curvature limit.
(docs/MATH.md §3.7)"""

from __future__ import annotations

import numpy as np

from checker.engine.frames import rotate_rows
from checker.engine.sizes import RowFrame
from checker.geometry.evaluate import evaluate_mixed
from checker.part import Part


def applies(cutter) -> bool:
    """True for the cutters whose bottom plane passes through the CC point (flat, r = 0)."""
    return cutter.flat_end


def flat_contour_limit(part: Part, frame: RowFrame, Q: np.ndarray, rows: np.ndarray,
                       sid: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """R_lim (K,) mm for (row, surface, uv) pairs: the CC point of row `rows[k]` lies on
    surface `sid[k]` at `uv[k]`; that surface's second derivatives give k_n along the row's
    horizontal tangent (tool frames `Q (N, 3, 3)`, normals and e of `frame`)."""
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1], order=2)
    su, sv = rotate_rows(Q, ev.du, rows), rotate_rows(Q, ev.dv, rows)
    suu, suv, svv = (rotate_rows(Q, d, rows) for d in (ev.duu, ev.duv, ev.dvv))
    n, e = frame.n[rows], frame.e[rows]
    t = np.column_stack([-e[:, 1], e[:, 0], np.zeros(len(rows))])  # z x e
    # t = a su + b sv (least squares through the first fundamental form)
    E, F, G = (np.einsum("ij,ij->i", x, y) for x, y in ((su, su), (su, sv), (sv, sv)))
    tu, tv = np.einsum("ij,ij->i", t, su), np.einsum("ij,ij->i", t, sv)
    det = E * G - F * F
    ok = det > 1e-24 * np.maximum(E * G, 1e-300)
    det = np.where(ok, det, 1.0)
    a, b = (G * tu - F * tv) / det, (E * tv - F * tu) / det
    second = suu * (a * a)[:, None] + 2.0 * suv * (a * b)[:, None] + svv * (b * b)[:, None]
    kn = np.einsum("ij,ij->i", n, second)
    nh = np.hypot(n[:, 0], n[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        lim = np.where(ok & (kn > 0.0) & (np.linalg.norm(e, axis=1) > 0.5), nh / kn, np.inf)
    return np.where(np.isfinite(lim) & (lim >= 0.0), lim, np.inf)
