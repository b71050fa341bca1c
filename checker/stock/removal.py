"""The material a program removes from the Z-dexel stock, and per move what each piece of the
tool removed (docs/MATH.md §14). Part frame, mm.

`remove` takes the program as items: the tool translating from tip `a[s]` to tip `b[s]` at the
constant unit axis `axis[s]` (a pose: a = b), each item belonging to move `move[s]` (items of
one move consecutive, moves in program order). A move whose axis turns is passed as a chain of
poses no tool point travels more than `step` between."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from checker.mesh.tool import ToolPieces
from checker.stock import swept_piece as sw
from checker.stock.dexels import Dexels

ENGAGE = 1e-3        # mm: a ray the body removes more than this from counts as engaged
CHUNK = 100_000      # items cut per kernel call
_NICE = (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)


@dataclass
class Removal:
    """Per move (M) and piece kind (0 body, 1 shank, 2 holder): `volume (M, 3)` mm^3 removed,
    `thickness (M, 3)` the largest length removed on one ray by one item (mm), `where (M, 3,
    3)` that ray's (x, y) and the z of the middle of its removed stretch (nan where nothing was
    removed), `width (M,)` the body's engaged width across the travel (mm: the extent of the
    rays it removed more than ENGAGE from, one ray's h included; a plunge: the larger of the
    x and y extents), `rays (M,)` how many rays the body removed more than ENGAGE from (summed
    over the move's items), `refused` cuts left undone for want of interval slots."""

    volume: np.ndarray
    thickness: np.ndarray
    where: np.ndarray
    width: np.ndarray
    rays: np.ndarray
    refused: int = 0


def default_resolution(extent) -> float:
    """A ray spacing h (mm) for a stock of `extent` (3,) mm: the finest of 0.01, 0.02, 0.05,
    0.1, 0.2, 0.5 (then 1, 2, 5) that keeps the rays within 4 million."""
    ex = np.asarray(extent, np.float64)
    area = max(float(ex[0]), 1e-9) * max(float(ex[1]), 1e-9)
    for h in _NICE:
        if area / (h * h) <= 4.0e6:
            return h
    return _NICE[-1]


def error_bound(h: float, step: float) -> tuple[float, float]:
    """(along_ray, lateral) mm. Along each ray the material is exact to the searches' 1e-6 mm
    for vertical translations; for sampled motion (any other axis) every point of the true
    sweep is within step/2 of a sampled pose's piece, so the removal is short by at most
    step/2. Between rays the model is the h x h column about each ray: lateral h / sqrt(2)."""
    return max(sw._TOL, 0.5 * float(step)), float(h) / math.sqrt(2.0)


def _clip_polygon(poly: np.ndarray, hmax: float) -> np.ndarray:
    """The convex polygon (k, 2) of (r, h) cut to h <= hmax (empty (0, 2) when none is left)."""
    out = []
    k = len(poly)
    for i in range(k):
        p, q = poly[i], poly[(i + 1) % k]
        pin, qin = p[1] <= hmax, q[1] <= hmax
        if pin:
            out.append(p)
        if pin != qin:
            t = (hmax - p[1]) / (q[1] - p[1])
            out.append(p + t * (q - p))
        if k == 1:
            break
    if not out:
        return np.zeros((0, 2))
    res = [out[0]]
    for v in out[1:]:
        if np.abs(v - res[-1]).max() > 1e-12:
            res.append(v)
    while len(res) > 1 and np.abs(res[-1] - res[0]).max() <= 1e-12:
        res.pop()
    return np.array(res)


def _prepared(pieces: ToolPieces, hmax: float):
    """The pieces holder-first (kind descending), cut to h <= hmax, with each one's type
    (cylinder, capsule, generic), its largest radius and its type's two heights."""
    order = np.argsort(-pieces.kind, kind="stable")
    polys, rhos, kinds = [], [], []
    for p in order:
        rho = float(pieces.rho[p])
        poly = _clip_polygon(pieces.prof[p, : pieces.nprof[p]], hmax - rho)
        if len(poly):
            polys.append(poly)
            rhos.append(rho)
            kinds.append(int(pieces.kind[p]))
    P = len(polys)
    prof = np.zeros((max(P, 1), max([len(q) for q in polys] + [1]), 2))
    nprof = np.zeros(max(P, 1), np.int64)
    ptype = np.zeros(max(P, 1), np.int64)
    rmax = np.zeros(max(P, 1))
    geo = np.zeros((max(P, 1), 2))
    for p, (poly, rho) in enumerate(zip(polys, rhos, strict=True)):
        prof[p, : len(poly)] = poly
        nprof[p] = len(poly)
        r, hh = poly[:, 0], poly[:, 1]
        rmax[p] = r.max() + rho
        geo[p] = hh.min(), hh.max()
        at_rmax = r >= r.max() - 1e-12
        if rho > 0.0 and np.all(r <= 1e-12):
            ptype[p] = sw.CAPSULE
        elif (rho == 0.0 and np.all((np.abs(hh - hh.min()) <= 1e-12)
                                    | (np.abs(hh - hh.max()) <= 1e-12))
              and np.any(at_rmax & (hh <= hh.min() + 1e-12))
              and np.any(at_rmax & (hh >= hh.max() - 1e-12))):
            ptype[p] = sw.CYLINDER
        elif (rho > 0.0 and len(poly) == 4 and r.max() > 1e-12
              and np.all((np.abs(hh - hh.min()) <= 1e-12) | (np.abs(hh - hh.max()) <= 1e-12))
              and np.all((r <= 1e-12) | (r >= r.max() - 1e-12))):
            ptype[p] = sw.BULL                 # the rectangle [0, R] x [h0, h1] grown by rho
    return (prof[:P], nprof[:P], np.array(rhos, np.float64), np.array(kinds, np.int64),
            ptype[:P], rmax[:P], geo[:P])


def _reach(stock: Dexels, a: np.ndarray, b: np.ndarray) -> float:
    """mm above the tip beyond which no piece can meet the stock: the farthest corner of the
    stock's box from any tip, plus 1 mm."""
    filled = stock.count > 0
    if not filled.any() or len(a) == 0:
        return 1.0
    zlo = float(stock.lo[:, :, 0][filled].min())
    k = np.maximum(stock.count.astype(np.int64) - 1, 0)[:, :, None]
    zhi = float(np.take_along_axis(stock.hi, k, axis=2)[:, :, 0][filled].max())
    lo = np.array([stock.x0, stock.y0, zlo])
    hi = np.array([stock.x0 + stock.nx * stock.h, stock.y0 + stock.ny * stock.h, zhi])
    far = 0.0
    for tips in (a, b):
        gap = np.maximum(np.abs(tips - lo), np.abs(tips - hi))
        far = max(far, float(np.sqrt((gap * gap).sum(axis=1)).max()))
    return far + 1.0


def _as_items(a, b, axis, move, n_moves):
    a = np.ascontiguousarray(a, np.float64).reshape(-1, 3)
    b = np.ascontiguousarray(b, np.float64).reshape(-1, 3)
    axis = np.ascontiguousarray(axis, np.float64).reshape(-1, 3)
    move = np.ascontiguousarray(move, np.int64).reshape(-1)
    S = len(a)
    if not (len(b) == S and len(axis) == S and len(move) == S):
        raise ValueError(f"a, b, axis and move need one row per item: {len(a)}, {len(b)}, "
                         f"{len(axis)}, {len(move)}")
    if S and (move.min() < 0 or move.max() >= n_moves or np.any(np.diff(move) < 0)):
        raise ValueError(f"move must be non-decreasing in [0, {n_moves}), found "
                         f"[{move.min()}, {move.max()}]")
    norm = np.linalg.norm(axis, axis=1)
    if S and (not np.all(np.isfinite(a)) or not np.all(np.isfinite(b))
              or np.any(np.abs(norm - 1.0) > 1e-6)):
        raise ValueError("a and b must be finite and every axis a unit vector")
    return a, b, axis / np.where(norm > 0, norm, 1.0)[:, None], move


def remove(stock: Dexels, pieces: ToolPieces, a, b, axis, move, n_moves: int, *,
           step: float, engage: float = ENGAGE) -> Removal:
    """Cut `stock` (mutated) by the tool `pieces` along the items (module docstring): `a, b,
    axis (S, 3)` mm and unit, `move (S,)` in [0, n_moves). `step` (mm, > 0) the largest
    travel between sampled poses of an item whose axis is not +z. Returns what each piece
    removed per move; `stock.overflow` grows by the cuts refused for want of slots."""
    if not step > 0.0:
        raise ValueError(f"step must be > 0 mm, found {step}")
    if not (stock.lo.dtype == np.float32 and stock.hi.dtype == np.float32
            and stock.count.dtype == np.uint8 and stock.lo.flags.c_contiguous
            and stock.hi.flags.c_contiguous and stock.count.flags.c_contiguous):
        raise ValueError("the stock's lo, hi must be C-contiguous float32 and count uint8")
    a, b, axis, move = _as_items(a, b, axis, move, n_moves)
    M = int(n_moves)
    empty = Removal(np.zeros((M, 3)), np.zeros((M, 3)), np.full((M, 3, 3), np.nan),
                    np.zeros(M), np.zeros(M, np.int64))
    if len(a) == 0 or len(pieces) == 0:
        return empty
    prof, nprof, rho, kind, ptype, rmax, geo = _prepared(pieces, _reach(stock, a, b))
    if len(prof) == 0:
        return empty
    out = empty
    n_ref = 0
    ntx = (stock.nx + sw.TILE - 1) // sw.TILE
    nty = (stock.ny + sw.TILE - 1) // sw.TILE
    for c in range(0, len(a), CHUNK):          # in order; bounds the statistics' memory
        ca, cb, cx = a[c:c + CHUNK], b[c:c + CHUNK], axis[c:c + CHUNK]
        win, zlow = sw.item_windows(prof, nprof, rho, ca, cb, cx, stock.x0, stock.y0,
                                    stock.h, stock.nx, stock.ny)
        start, item = sw.bin_items(win, ntx, nty)
        st, refused = sw.sweep(stock.lo, stock.hi, stock.count, stock.x0, stock.y0, stock.h,
                               prof, nprof, rho, kind, ptype, rmax, geo, ca, cb, cx,
                               float(step), float(engage), win, zlow, start, item)
        part = Removal(*sw.per_move(st, item, move[c:c + CHUNK], M, stock.h))
        out = part if c == 0 else _merged(out, part)
        n_ref += int(refused.sum())
    stock.overflow += n_ref
    out.refused = n_ref
    return out


def _merged(x: Removal, y: Removal) -> Removal:
    """The statistics of two runs of items over the same moves, one after the other."""
    deeper = y.thickness > x.thickness
    return Removal(x.volume + y.volume, np.maximum(x.thickness, y.thickness),
                   np.where(deeper[:, :, None], y.where, x.where),
                   np.maximum(x.width, y.width), x.rays + y.rays)
