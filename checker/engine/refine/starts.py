"""Where the local refinement starts, per CC row: the scan's seeds (sampled local minima), the
crossings of the bottom-plane contour (flat-bottomed cutters), the surfaces the CC point lies
on (around which rings.py places its starts), and the nearest test points of the other surfaces
at a seam. (docs/MATH.md §6.1-§6.2)"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.engine.scan.contour import Crossings
from checker.geometry.evaluate import evaluate_mixed
from checker.geometry.inverse import invert_points
from checker.geometry.sampling import TestPoints
from checker.part import Part

ON_SURFACE = 1e-3  # mm: a CC point this close to a surface lies on it


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
