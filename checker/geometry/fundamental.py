"""The fundamental forms at surface points, on (u, v) steps: tangent vectors to (u, v) through the
first fundamental form, and the second fundamental form with a given normal; an orthonormal
tangent basis to express directions in. Any frame (the
forms only need the derivatives and the normal in the same one); mm and parameter units."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def uv_of_tangents(du: np.ndarray, dv: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """For K surface points with derivatives `du`, `dv` (K, 3): `f(t (K, ..., 3)) -> (K, ..., 2)`,
    the (u, v) steps w whose images `du w_u + dv w_v` are the least-squares fits of the tangent
    vectors t, `w = G^-1 [du dv]^T t` with G the first fundamental form (0 where G is
    singular)."""
    E, F, G = (np.einsum("ij,ij->i", a, b) for a, b in ((du, du), (du, dv), (dv, dv)))
    det = E * G - F * F
    inv = np.where(det > 0.0, 1.0 / np.where(det > 0.0, det, 1.0), 0.0)

    def f(t: np.ndarray) -> np.ndarray:
        extra = (1,) * (t.ndim - 2)
        e, fk, g, i = (x.reshape(-1, *extra) for x in (E, F, G, inv))
        bu = np.einsum("k...i,ki->k...", t, du)
        bv = np.einsum("k...i,ki->k...", t, dv)
        return np.stack([(g * bu - fk * bv) * i, (e * bv - fk * bu) * i], axis=-1)

    return f


def second_form(n: np.ndarray, second: tuple[np.ndarray, np.ndarray, np.ndarray],
                w1: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """II(w1, w2) (K,) = n . (a1 a2 S_uu + (a1 b2 + a2 b1) S_uv + b1 b2 S_vv) for (u, v) steps
    `w1 = (a1, b1)`, `w2 = (a2, b2)` (K, 2), `second` = (S_uu, S_uv, S_vv) and normals `n`
    (K, 3): the normal curvature times |t|^2 for w1 = w2 the step of a tangent t."""
    suu, suv, svv = second
    (a1, b1), (a2, b2) = w1.T, w2.T
    d2 = (suu * (a1 * a2)[:, None] + suv * (a1 * b2 + a2 * b1)[:, None]
          + svv * (b1 * b2)[:, None])
    return np.einsum("ij,ij->i", n, d2)


def tangent_basis(du: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangent vectors (t1, t2) (K, 3) at K surface points with unit normals `n`
    (K, 3): t1 along `du`'s part normal to n, t2 = n x t1."""
    t1 = du - np.einsum("ij,ij->i", du, n)[:, None] * n
    t1 = t1 / np.maximum(np.linalg.norm(t1, axis=1, keepdims=True), 1e-300)
    return t1, np.cross(n, t1)
