"""The surface to third order at CC points (docs/MATH.md §11.1): normal, principal curvatures
and directions, and the cubic terms of the local Taylor (Monge) expansion in the principal
frame, from the exact NURBS derivatives up to order 3. Part frame, mm, 1/mm, 1/mm^2.

In the principal frame (`d1`, `d2`, `n`) at the point, with `X`, `Y` along `d1`, `d2` and `Z`
the height along the normal `n` (out of the material, towards the tool), the surface is

    Z = -(k1 X^2 + k2 Y^2) / 2 + (a X^3 + 3 b X^2 Y + 3 c X Y^2 + d Y^3) / 6 + O(4),

`k1 >= k2` in the convention of `checker.geometry.evaluate.Curvatures` (positive: convex as
the tool sees it). Liu et al. (n.d., eq. 12) write the same expansion to second order (`f_xx`,
`f_xy`, `f_yy`; here `f_xy = 0` by the choice of frame). The cubic coefficients are the derivatives
of the principal curvatures (bending towards the tool, `-k1`, `-k2`) along the principal directions:
`a = d(-k1)/dX`, `b = d(-k1)/dY`, `c = d(-k2)/dX`, `d = d(-k2)/dY`."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.geometry.evaluate import SurfaceEval, curvatures_of, evaluate_mixed
from checker.geometry.fundamental import second_form, uv_of_tangents
from checker.part import Part


class LocalSurface(NamedTuple):
    """Per CC point (N,): `point`, unit `normal`, unit principal directions `d1`, `d2` (N, 3),
    principal curvatures `k1 >= k2` (N,) 1/mm, and `cubic (N, 4)` = (a, b, c, d) 1/mm^2 (module
    docstring)."""

    point: np.ndarray
    normal: np.ndarray
    d1: np.ndarray
    d2: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    cubic: np.ndarray

    def normal_curvature(self, t: np.ndarray) -> np.ndarray:
        """(N,) normal curvature (1/mm, positive convex) along unit tangents `t (N, 3)` (Euler)."""
        c, s = _cos_sin(self, t)
        return self.k1 * c * c + self.k2 * s * s

    def section_cubic(self, t: np.ndarray) -> np.ndarray:
        """(N,) the third derivative (1/mm^2) of the normal section's height along unit tangents
        `t (N, 3)`: `Z'''(0)` of `Z(x) = Z(x t)`, i.e. `d kappa / ds` at the point of the
        section's curvature bending towards the tool."""
        c, s = _cos_sin(self, t)
        a, b, cc, d = self.cubic.T
        return a * c ** 3 + 3.0 * b * c * c * s + 3.0 * cc * c * s * s + d * s ** 3

    def offset(self, r: float) -> LocalSurface:
        """The parallel surface `r` mm towards the tool (the bull-nose's corner-centre surface,
        Liu et al. n.d., §5, Fig. 3): the same normal and principal directions, curvatures
        `k / (1 + r k)`, and cubic terms divided by `(1 + r k_i)^2 (1 + r k_j)` (the derivative
        of `k_i` along `d_j`, with arc length scaled by `1 + r k_j` there)."""
        m1, m2 = 1.0 + r * self.k1, 1.0 + r * self.k2
        scale = np.column_stack([m1 ** 3, m1 * m1 * m2, m2 * m2 * m1, m2 ** 3])
        return LocalSurface(self.point + r * self.normal, self.normal, self.d1, self.d2,
                            self.k1 / m1, self.k2 / m2, self.cubic / scale)


def _cos_sin(ls: LocalSurface, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=float).reshape(-1, 3)
    return np.einsum("ij,ij->i", t, ls.d1), np.einsum("ij,ij->i", t, ls.d2)


def local_surface(part: Part, surface_ids, u, v) -> LocalSurface:
    """The surface to third order at N CC points given as (surface id, u, v) (N,) each."""
    return local_surface_of(evaluate_mixed(part, surface_ids, u, v, order=3))


def local_surface_of(ev: SurfaceEval) -> LocalSurface:
    """The surface to third order from an order-3 evaluation."""
    if ev.duuu is None:
        raise ValueError("the cubic terms need an order=3 evaluation")
    cv = curvatures_of(ev)
    h = lambda p: _section_third(ev, p)  # noqa: E731
    a, d = h(cv.d1), h(cv.d2)
    plus, minus = h(cv.d1 + cv.d2), h(cv.d1 - cv.d2)  # the cubic at (1, 1) and (1, -1)
    b = ((plus - minus) / 2.0 - d) / 3.0
    c = ((plus + minus) / 2.0 - a) / 3.0
    return LocalSurface(ev.points, ev.normals, cv.d1, cv.d2, cv.k1, cv.k2,
                        np.column_stack([a, b, c, d]))


def _section_third(ev: SurfaceEval, p: np.ndarray) -> np.ndarray:
    """(N,) `6 Z3(p)`: the cubic term of the height along the normal over the tangent-plane
    vector `p (N, 3)`. With `S(w)`, `w = (du, dv)`, the tangent-plane offset is
    `p = J w + Q(w) / 2 + O(3)` and the height `Z = II(w, w) / 2 + C(w) / 6 + O(4)`; inverting,
    `w = q - J^-1 Q(q) / 2`, `q = J^-1 p`, so `6 Z3(p) = C(q) - 3 II(q, J^-1 Q(q))`, where
    `J^-1 x = G^-1 [S_u S_v]^T x` for tangent vectors (`G` the first fundamental form) and
    `II`, `C` the normal parts of the second and third derivatives."""
    to_uv = uv_of_tangents(ev.du, ev.dv)
    q = to_uv(p)
    qu, qv = q.T
    second = (ev.duu, ev.duv, ev.dvv)
    quad = (qu * qu)[:, None] * ev.duu + (2.0 * qu * qv)[:, None] * ev.duv + \
        (qv * qv)[:, None] * ev.dvv
    third = (qu ** 3)[:, None] * ev.duuu + (3.0 * qu * qu * qv)[:, None] * ev.duuv + \
        (3.0 * qu * qv * qv)[:, None] * ev.duvv + (qv ** 3)[:, None] * ev.dvvv
    return (np.einsum("ij,ij->i", third, ev.normals)
            - 3.0 * second_form(ev.normals, second, q, to_uv(quad)))
