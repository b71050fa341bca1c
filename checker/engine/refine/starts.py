"""Where the local refinement starts, per CC row: the scan's seeds (sampled local minima), the
crossings of the bottom-plane contour (flat-bottomed cutters), points on rings around the CC
point on each surface it lies on (with the size's limit at the CC point itself), and the nearest
test points of the other surfaces at a seam. (docs/MATH.md §6.1-§6.3)"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.engine.grid.frames import rotate_rows
from checker.engine.scan.contour import Crossings
from checker.engine.sizes import RowFrame, pair_sizes
from checker.geometry.evaluate import evaluate_mixed, points_mixed
from checker.geometry.fundamental import tangent_basis, uv_of_tangents
from checker.geometry.inverse import invert_points
from checker.geometry.sampling import TestPoints
from checker.part import Part

ON_SURFACE = 1e-3  # mm: a CC point this close to a surface lies on it
_FIRST_RING = 16  # directions on the first ring around a CC point
_RING_RATIO = 3.0  # the wider rings' radii grow by at most this


class Starts(NamedTuple):
    """Refinement starts: CC `rows (S,)`, `surface (S,)`, `uv (S, 2)` and the initial stencil
    half-widths `step (S, 2)` (parameter units)."""

    rows: np.ndarray
    surface: np.ndarray
    uv: np.ndarray
    step: np.ndarray

    @staticmethod
    def join(parts: list[Starts]) -> Starts:
        """The starts of all `parts`, in order."""
        return Starts._make(np.concatenate(field) for field in zip(*parts, strict=True))


class Contacts(NamedTuple):
    """The surfaces the CC points lie on, one (row, surface) pair each: `rows (K,)`,
    `surface (K,)`, `uv (K, 2)` the CC point's parameters on it."""

    rows: np.ndarray
    surface: np.ndarray
    uv: np.ndarray


class CCLimits(NamedTuple):
    """The size's limits at CC points themselves: `rows (K,)`, `size (K,)` mm, on `surface
    (K,)` at `uv (K, 2)`."""

    rows: np.ndarray
    size: np.ndarray
    surface: np.ndarray
    uv: np.ndarray


def seed_starts(tp: TestPoints, part: Part, seeds: np.ndarray) -> Starts:
    """Starts at the scan's seeds `seeds (N, m)` (test points, -1 pad)."""
    srow, col = np.nonzero(seeds >= 0)
    idx = seeds[srow, col]
    keep = tp.surface[idx] >= 0
    srow, idx = srow[keep], idx[keep]
    sid = tp.surface[idx].astype(np.int64)
    uv = tp.uv[idx]
    return Starts(srow, sid, uv, per_parameter(part, sid, uv, 0.5 * tp.spacing[idx]))


def contour_starts(tp: TestPoints, part: Part, crossings: Crossings) -> Starts:
    """Starts on the bottom-plane contour of flat-bottomed cutters (scan/contour.py), uv
    interpolated along the crossing sample edges."""
    p, q, f = crossings.p, crossings.q, crossings.fraction
    sid = tp.surface[p].astype(np.int64)
    uv = tp.uv[p] + f[:, None] * (tp.uv[q] - tp.uv[p])
    return Starts(crossings.rows, sid, uv, per_parameter(part, sid, uv, 0.25 * tp.spacing[p]))


def per_parameter(part: Part, sid: np.ndarray, uv: np.ndarray, mm: np.ndarray) -> np.ndarray:
    """(K, 2) lengths `mm (K,)` expressed in u and in v at the surface points (sid, uv):
    mm / |S_u|, mm / |S_v|."""
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1])
    return np.column_stack([mm / np.maximum(np.linalg.norm(ev.du, axis=1), 1e-12),
                            mm / np.maximum(np.linalg.norm(ev.dv, axis=1), 1e-12)])


def _nearest_of_other_surfaces(sid: np.ndarray, own: np.ndarray) -> np.ndarray:
    """(N, k) mask of the entries of sorted nearest-neighbour rows whose surface `sid (N, k)`
    no nearer entry of the row has, other than the row's own surface `own (N,)`: the nearest
    test point of each other surface."""
    first = np.ones(sid.shape, dtype=bool)
    for j in range(1, sid.shape[1]):
        first[:, j] = (sid[:, :j] != sid[:, j:j + 1]).all(axis=1)
    return first & (sid != own[:, None]) & (sid >= 0)


def contact_pairs(tp: TestPoints, part: Part, knn: np.ndarray, own: np.ndarray,
                  uv_own: np.ndarray, cc: np.ndarray) -> Contacts:
    """Every surface each CC point `cc (N, 3)` (part frame) lies on: its own (`own`, `uv_own`,
    where known) and, on a seam, every other surface of its nearest test points `knn (N, k)`
    that passes within `ON_SURFACE` mm of it (uv by inversion from that test point)."""
    has = (own >= 0) & np.isfinite(uv_own).all(axis=1)
    rows, sids, uvs = [np.flatnonzero(has)], [own[has]], [uv_own[has]]
    sid = tp.surface[knn]
    r, j = np.nonzero(_nearest_of_other_surfaces(sid, own))
    idx = knn[r, j]
    for s in np.unique(tp.surface[idx]):
        sel = np.flatnonzero(tp.surface[idx] == s)
        u, v, dist = invert_points(part.surfaces[int(s)], cc[r[sel]], tp.uv[idx[sel], 0],
                                   tp.uv[idx[sel], 1])
        ok = dist <= ON_SURFACE
        rows.append(r[sel][ok])
        sids.append(np.full(int(ok.sum()), s, dtype=np.int64))
        uvs.append(np.column_stack([u, v])[ok])
    return Contacts(np.concatenate(rows), np.concatenate(sids).astype(np.int64),
                    np.concatenate(uvs))


def seam_starts(tp: TestPoints, part: Part, knn: np.ndarray, own: np.ndarray,
                spacing: float) -> Starts:
    """Where the CC point lies on or near a seam: among its nearest test points, the nearest one
    on each other surface within one spacing starts a refinement (the rings cover the surfaces
    the CC point lies on, these the ones it only comes near)."""
    n, k = knn.shape
    sid = tp.surface[knn]
    rows = np.repeat(np.arange(n), k)
    d = np.linalg.norm(tp.points[knn] - tp.points[knn[:, :1]], axis=2)  # from the nearest one
    pick = (_nearest_of_other_surfaces(sid, own) & (d <= spacing)).ravel()
    idx = knn.ravel()[pick]
    sid = tp.surface[idx].astype(np.int64)
    return Starts(rows[pick], sid, tp.uv[idx], per_parameter(part, sid, tp.uv[idx],
                                                              0.25 * tp.spacing[idx]))


def ring_radii(ring: float, spacing: float) -> list[float]:
    """The rings probed around a CC point (mm): `ring` (its own curvature), then radii growing by
    at most _RING_RATIO up to half the test-point spacing, and 1.5 spacings. Near the CC point
    the size is the curvature limit plus a term linear in the distance (third-order contact),
    so a minimum can lie at any distance below the samples' resolution, where no Newton walk
    from the first ring reaches it (a cone's tip); a ring within a factor of it does."""
    top = max(0.5 * spacing, ring)
    count = int(np.ceil(np.log(top / ring) / np.log(_RING_RATIO))) + 1
    return [*np.geomspace(ring, top, max(count, 2)).tolist(), 1.5 * spacing]


def ring_evaluations(radii: list[float]) -> int:
    """Sizes evaluated on the rings of `radii` around one CC point on one surface
    (`ring_starts`): _FIRST_RING on the first, 10 on each wider one."""
    return _FIRST_RING + 10 * (len(radii) - 1)


def ring_starts(part: Part, cutter, frame: RowFrame, Q: np.ndarray, contacts: Contacts,
                radii: list[float], toward: np.ndarray) -> tuple[Starts, CCLimits]:
    """Around each CC point, on each surface it lies on (`contacts`), points on rings of `radii`
    (mm) in directions even in the tangent plane (not in (u, v)): _FIRST_RING of them on the
    first ring, which probes the curvature limit at the CC point; the direction of the
    closed-form limit (`toward (K, 3)`, part frame, NaN where none: limits.py), else the first
    ring's best (interpolated between the samples), and the opposite one, with 8 even ones, on
    every wider ring: the narrow valleys near the CC point that the samples do not resolve leave
    it along that direction (a sector a few degrees wide at 0.01 mm). The best point of each
    ring is a refinement start (stencil half-width: the first ring's radius, then half the
    ring's). Returns the starts and the limits at the CC points themselves: along the best
    direction the size is s0 + b rho + O(rho^2) (third-order contact); where b > 0 the infimum
    is s0, at the CC point, which no point reaches: extrapolated from rho and rho/2
    (Richardson) where the closed form does not apply (docs/MATH.md §6.2, §6.3)."""
    rows, sid, uv = contacts.rows, contacts.surface, contacts.uv
    ev = evaluate_mixed(part, sid, uv[:, 0], uv[:, 1])
    dom = part.domains
    lo, hi = dom[sid, :, 0], dom[sid, :, 1]
    per_mm = 1.0 / np.maximum(np.column_stack([np.linalg.norm(ev.du, axis=1),
                                               np.linalg.norm(ev.dv, axis=1)]), 1e-12)
    nrm = np.cross(ev.du, ev.dv)  # the parametrisation's normal (the ring's sense of angles)
    t1, t2 = tangent_basis(ev.du, nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True),
                                                   1e-300))
    to_uv = _tangent_to_uv(ev.du, ev.dv, t1, t2)
    even = np.arange(8) * np.pi / 4
    first = np.arange(_FIRST_RING) * 2 * np.pi / _FIRST_RING
    angles = np.broadcast_to(first, (len(rows), _FIRST_RING))
    out = []
    for j, radius in enumerate(radii):
        m = angles.shape[1]
        step = radius * to_uv(angles)  # (K, m, 2)
        ring = np.clip(uv[:, None, :] + step, lo[:, None], hi[:, None])
        pts = points_mixed(part, np.repeat(sid, m), ring[..., 0].ravel(), ring[..., 1].ravel())
        f = pair_sizes(cutter, frame, np.repeat(rows, m),
                       rotate_rows(Q, pts, np.repeat(rows, m))).reshape(-1, m)
        k = np.argmin(f, axis=1)
        ar = np.arange(len(rows))
        ok = np.isfinite(f[ar, k])
        half = radius * per_mm * (1.0 if j == 0 else 0.5)
        out.append(Starts(rows[ok], sid[ok], ring[ar, k][ok], half[ok]))
        if j == 0:
            known = np.isfinite(toward).all(axis=1)  # the closed form's direction (limits.py)
            best = np.where(known, np.arctan2(np.einsum("ij,ij->i", toward, t2),
                                              np.einsum("ij,ij->i", toward, t1)),
                            _best_angle(f, first))
            at_cc = _limit_at_cc(cutter, frame, Q, part, contacts, lo, hi, to_uv, best, radius,
                                 ~known)
            angles = np.column_stack([best, best + np.pi, np.broadcast_to(even, (len(rows), 8))])
    return Starts.join(out), at_cc


def _limit_at_cc(cutter, frame: RowFrame, Q: np.ndarray, part: Part, contacts: Contacts, lo, hi,
                 to_uv, angle: np.ndarray, radius: float, wanted: np.ndarray) -> CCLimits:
    """The size's limit at the `wanted` CC points (`ring_starts`; the others have it in closed
    form) along `angle`, 2 s(rho/2) - s(rho) with rho = `radius`; the opposite direction where
    that one leaves the surface's domain (a CC point on its boundary; the curvature is the
    same); docs/MATH.md §6.3."""
    rows, sid, uv = contacts.rows, contacts.surface, contacts.uv
    step = radius * to_uv(angle[:, None])[:, 0]
    out = (uv + step < lo) | (uv + step > hi)
    step = np.where(out.any(axis=1)[:, None], -step, step)
    near = np.clip(uv + 0.5 * step, lo, hi)
    far = np.clip(uv + step, lo, hi)
    pts = points_mixed(part, np.tile(sid, 2), np.r_[near[:, 0], far[:, 0]],
                       np.r_[near[:, 1], far[:, 1]])
    f = pair_sizes(cutter, frame, np.tile(rows, 2), rotate_rows(Q, pts, np.tile(rows, 2)))
    f_near, f_far = f[:len(rows)], f[len(rows):]
    ok = np.isfinite(f_near) & np.isfinite(f_far) & wanted
    limit = np.maximum(np.minimum(2.0 * f_near[ok] - f_far[ok], f_near[ok]), 0.0)
    return CCLimits(rows[ok], limit, sid[ok], uv[ok])


def _tangent_to_uv(du: np.ndarray, dv: np.ndarray, t1: np.ndarray, t2: np.ndarray):
    """`f(angles (K, m)) -> (K, m, 2)`: the (u, v) steps of unit length in the tangent plane at
    K surface points (derivatives du, dv (K, 3); orthonormal tangents t1, t2 (K, 3)), at
    `angles` (rad) from t1 towards t2."""
    to_uv = uv_of_tangents(du, dv)

    def f(angles: np.ndarray) -> np.ndarray:
        return to_uv(np.cos(angles)[..., None] * t1[:, None]
                     + np.sin(angles)[..., None] * t2[:, None])

    return f


def _best_angle(f: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(K,) the angle of the smallest of K rows of values `f (K, m)` at even `angles (m,)`,
    between the samples by a parabola through the best and its two neighbours (the sample
    where they are not finite)."""
    m = len(angles)
    k = np.argmin(f, axis=1)
    ar = np.arange(len(f))
    a, b, c = f[ar, (k - 1) % m], f[ar, k], f[ar, (k + 1) % m]
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = 0.5 * (a - c) / (a - 2.0 * b + c)
    shift = np.where(np.isfinite(shift), np.clip(shift, -0.5, 0.5), 0.0)
    return angles[k] + shift * (2.0 * np.pi / m)
