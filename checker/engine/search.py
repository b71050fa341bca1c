"""The global scan: the exact minimum of the imaginary size over all test points of the part
per CC row, with sound pruning (family.py) and doubling of the trial size, then up to m seed
points per row in distinct basins for the local refinement."""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from checker.engine.candidates import CellGrid, disc_candidates
from checker.engine.contour import contour_seeds
from checker.engine.sizes import RowFrame, csr_sizes

_GROW = 4.0
_CHUNK_ROWS = 1024
_REL_MARGIN = 0.2


@dataclass
class Scan:
    """Per row: `best (N,)` smallest sampled size (inf: none below the size cap), `arg (N,)`
    its test point (-1 none), `seeds (N, m)` test points starting the refinement (-1 pad),
    `seed_size (N, m)` their sizes, `evaluations (N,)` kernel evaluations spent, `crossings`
    (rows, p, q, fraction) of the bottom-plane contour seeds or None."""

    best: np.ndarray
    arg: np.ndarray
    seeds: np.ndarray
    seed_size: np.ndarray
    evaluations: np.ndarray
    crossings: tuple | None = None


@nb.njit(cache=True)
def _basins(indptr, indices, values, knn, m, rel, absm, best, arg, seeds, seed_size):
    """Per row: smallest value and its point, then up to m seeds: the candidates that are
    sampled local minima (no candidate among their nearest test points is smaller), by
    increasing value, within `rel * best + absm` of the best."""
    npts = knn.shape[0]
    stamp = np.full(npts, -1, dtype=np.int64)
    pos = np.zeros(npts, dtype=np.int64)
    for i in range(indptr.shape[0] - 1):
        a, b = indptr[i], indptr[i + 1]
        for k in range(a, b):
            stamp[indices[k]] = i
            pos[indices[k]] = k
        vbest = np.inf
        for k in range(a, b):
            if values[k] < vbest:
                vbest = values[k]
                best[i] = vbest
                arg[i] = indices[k]
        if not np.isfinite(vbest):
            continue
        limit = vbest * (1.0 + rel) + absm
        taken = 0
        for k in range(a, b):
            v = values[k]
            if v > limit:
                continue
            p = indices[k]
            local = True
            for t in range(knn.shape[1]):
                q = knn[p, t]
                if q >= 0 and q < npts and stamp[q] == i and values[pos[q]] < v:
                    local = False
                    break
            if not local:
                continue
            if taken < m:
                seeds[i, taken] = p
                seed_size[i, taken] = v
                taken += 1
            else:
                worst = 0
                for t in range(1, m):
                    if seed_size[i, t] > seed_size[i, worst]:
                        worst = t
                if v < seed_size[i, worst]:
                    seeds[i, worst] = p
                    seed_size[i, worst] = v


def scan(cutter, frame: RowFrame, grid: CellGrid, s_start: np.ndarray, s_cap: float,
         slack: float, m: int, knn: np.ndarray, crossings: tuple[int, float] | None = None,
         rot: np.ndarray | None = None, first: np.ndarray | None = None) -> Scan:
    """Exact sampled minimum per row from finite trial sizes `s_start (N,)`. A row with trial
    size s looks at every test point within `slack` mm (half the sample spacing) of the disc,
    slab and ball of s (family.py); when its minimum is <= s it is the minimum over all test
    points (any point below s lies there), otherwise s grows by 4 up to `s_cap` (beyond it the
    row is unbounded). Seeds: see `_basins`. `crossings` (count, separation mm): also collect
    that many bottom-plane contour crossings per row (contour.py) from the final candidates.
    `rot (N, 3, 3)`: each row's tool frame seen from the grid's (default: the grid's frame).
    `first (N,)`: smaller first trial sizes for rows whose `s_start` is an upper bound of their
    minimum: such a row stops below s_start only once its disc holds every point up to its seed
    limit (or s_start), so best, arg and seeds are those of a start at s_start."""
    n = len(s_start)
    best = np.full(n, np.inf)
    arg = np.full(n, -1, dtype=np.int64)
    seeds = np.full((n, m), -1, dtype=np.int64)
    seed_size = np.full((n, m), np.inf)
    evals = np.zeros(n, dtype=np.int64)
    s_goal = np.minimum(s_start, s_cap)
    s_try = s_goal.copy() if first is None else np.minimum(first, s_goal)
    s_next = np.empty(n)
    active = np.arange(n)
    fam = frame.fam
    plane = np.column_stack([frame.n, np.einsum("ij,ij->i", frame.n, frame.cc) - slack])
    cross: list[tuple] = []
    while active.size:
        still = []
        for c0 in range(0, active.size, _CHUNK_ROWS):
            rows = active[c0:c0 + _CHUNK_ROWS]
            s = s_try[rows]
            sub = fam.take(rows)
            rot_rows = None if rot is None else rot[rows]
            sphere, zeq = sub.lower_ball(s, slack)
            indptr, idx = disc_candidates(grid, sub.centre(s), sub.radius(s) + slack,
                                          sub.z_low(s) - slack, sub.z_top + slack, sphere, zeq,
                                          plane[rows], rot_rows)
            counts = np.diff(indptr)
            vals = csr_sizes(cutter, frame, rows, grid.xyz, indptr, idx, rot_rows)
            evals[rows] += counts
            b = np.full(len(rows), np.inf)
            a = np.full(len(rows), -1, dtype=np.int64)
            sd = np.full((len(rows), m), -1, dtype=np.int64)
            ss = np.full((len(rows), m), np.inf)
            _basins(indptr, idx, vals, knn, m, _REL_MARGIN, slack, b, a, sd, ss)
            done = (b <= s) | (s >= s_cap)
            early = s < s_goal[rows]  # below the given start: stop only with complete seeds
            target = np.minimum(b * (1.0 + _REL_MARGIN) + slack, s_goal[rows])
            done = np.where(early, (b <= s) & (s >= target), done)
            s_next[rows] = np.where(early, target, s * _GROW)
            keep = done & (b <= s)
            best[rows[keep]], arg[rows[keep]] = b[keep], a[keep]
            seeds[rows[keep]], seed_size[rows[keep]] = sd[keep], ss[keep]
            if crossings is not None:
                r, p, q, f, _ = contour_seeds(cutter, frame.cc[rows], frame.n[rows],
                                              frame.e[rows], fam.z0[rows], grid.xyz, knn,
                                              indptr, idx, *crossings, rot=rot_rows)
                ok = keep[r]
                cross.append((rows[r[ok]], p[ok], q[ok], f[ok]))
            still.append(rows[~done])
        active = np.concatenate(still) if still else active[:0]
        s_try[active] = np.minimum(s_next[active], s_cap)
    found = tuple(np.concatenate([c[t] for c in cross]) for t in range(4)) if cross else None
    return Scan(best, arg, seeds, seed_size, evals, found)
