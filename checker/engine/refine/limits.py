"""The allowable size in the limit P -> Pcc, in closed form: the curvature limit.

Near Pcc the cutter and the surface share the tangent plane; both bend away from it by their
normal curvatures (positive towards the tool, tool frame). No point near Pcc is cut while the
cutter bends at least as much as the surface in every tangent direction, i.e. while
K_tool(s) - K_surf is positive semidefinite (2x2 second fundamental forms in one orthonormal
tangent basis). The smallest such s is the infimum of the size at Pcc, which no sample and no
local step reaches (the points within the exclusion radius are the CC point itself), and which
the rings of refinement starts only approach when its direction is not sharp.

Ball family (sphere of radius s):  K_tool = I / s, so s_lim = 1 / k_max (inf when k_max <= 0).

The closed forms are the cutter's (`Cutter.curvature_limit`); this module gives them the
surface's second fundamental form in the row's tool frame and keeps the limit where it holds.

R family on the corner (fillet contact, `Cutter.contact_case`; flat end-mills with
r = 0 on their bottom edge): a torus of tube radius r about a circle of radius R = s. In the basis
(t_m, t_c), t_c = z x e horizontal and t_m = t_c x n in the plane of the axis and n, its normal
curvatures are 1/r (meridian) and h / (R + r h) (parallel circle, Meusnier; h = |n_h|), no
twist. With K_surf = [[a, b], [b, c]] in that basis, PSD means 1 - a r >= 0 and

    h / (R + r h) >= c + b^2 r / (1 - a r) =: k,   so   R_lim = h / k - r h,

inf when k <= 0, 0 when 1 - a r <= 0 (the corner alone bends less than the surface). For r = 0
this is R_lim = h / k_n(t_c): the bottom plane's contour through Pcc (docs/MATH.md §3.7).
Tip contact (psi > 0, n_z > cos(psi)) and rows without a direction e have no limit here. The
limit is kept only where the surface's own normal is the row's (not the other side of a crease:
there the size tends to 0 or inf, not to a curvature limit) and its direction, +t or -t, leads
into the surface's parameter box. Where the closed form holds and is inf (no direction bends
towards the tool more than the cutter can), that is the limit: nothing is extrapolated there.
(docs/MATH.md §3.7)"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.engine.grid.rotations import rotate_rows
from checker.engine.sizes import RowFrame
from checker.geometry.evaluate import evaluate_mixed
from checker.geometry.fundamental import second_form, tangent_basis, uv_of_tangents
from checker.part import Part

_COS_SAME = np.cos(1e-4)  # the surface's normal within 1e-4 rad of the row's: tangent contact


class CurvatureLimit(NamedTuple):
    """Per (row, surface, uv) pair: the limit `size` (K,) mm (inf where none applies), the
    tangent `direction` (K, 3) (tool frame; its sign free) along which the size tends to it
    (NaN where none applies), and `settled` (K,): the closed form holds there, so its size is
    the limit even where that is inf (the surface bends away from the tool, or is flat, in every
    direction) and no extrapolation may replace it (rings.py)."""

    size: np.ndarray
    direction: np.ndarray
    settled: np.ndarray


def curvature_limit(cutter, part: Part, frame: RowFrame, Q: np.ndarray, rows: np.ndarray,
                    sid: np.ndarray, uv: np.ndarray) -> CurvatureLimit:
    """The limit for (row, surface, uv) pairs: the CC point of row `rows[k]` lies on surface
    `sid[k]` at `uv[k]`; that surface's second derivatives, seen in the row's tool frame
    (`Q (N, 3, 3)`, normals and e of `frame`), give it (module docstring)."""
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1], order=2)
    su, sv = rotate_rows(Q, ev.du, rows), rotate_rows(Q, ev.dv, rows)
    second = [rotate_rows(Q, d, rows) for d in (ev.duu, ev.duv, ev.dvv)]
    n = frame.n[rows]
    to_uv = uv_of_tangents(su, sv)
    closed = cutter.curvature_limit(n, frame.e[rows], lambda: tangent_basis(su, n),
                                    lambda t1, t2: _forms(n, second, to_uv, t1, t2))
    lim, t, form = closed.size, closed.direction, closed.form
    tangent = np.einsum("ij,ij->i", rotate_rows(Q, ev.normals, rows), n) >= _COS_SAME
    ok = np.isfinite(lim) & tangent & _leads_inside(part, sid, uv, to_uv(t))
    return CurvatureLimit(np.where(ok, np.maximum(lim, 0.0), np.inf),
                          np.where(ok[:, None], t, np.nan),
                          ok | (form & tangent & np.isinf(lim)))


def _forms(n: np.ndarray, second: list, to_uv, t1: np.ndarray, t2: np.ndarray):
    """(a, b, c) (K,): II(t1, t1), II(t1, t2), II(t2, t2) for tangents t1, t2 (K, 3)."""
    w1, w2 = to_uv(t1), to_uv(t2)
    return (second_form(n, second, w1, w1), second_form(n, second, w1, w2),
            second_form(n, second, w2, w2))


def _leads_inside(part: Part, sid: np.ndarray, uv: np.ndarray, step: np.ndarray) -> np.ndarray:
    """(K,) whether +step or -step from uv (K, 2) stays in the parameter box of surface sid."""
    dom = part.domains
    lo, hi = dom[sid, :, 0], dom[sid, :, 1]
    unit = step / np.maximum(np.abs(step).max(axis=1, keepdims=True), 1e-300)
    tiny = 1e-9 * (hi - lo)

    def inside(p):
        return ((p >= lo - tiny) & (p <= hi + tiny)).all(axis=1)

    eps = 1e-6 * (hi - lo).max(axis=1, keepdims=True)
    return inside(uv + eps * unit) | inside(uv - eps * unit)
