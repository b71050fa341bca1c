"""Seeds of the local refinement for one CC row: the sampled local minima of the imaginary size
among the row's evaluated test points, then near-minimal samples in the slots left (numba)."""

from __future__ import annotations

import numba as nb
import numpy as np

NEAR_TIE = 2e-4  # relative: a sample whose lower neighbours are all lower by less is near-minimal


@nb.njit(cache=True, forceinline=True)
def _lowest_neighbour(i, p, knn, values, stamp, pos):
    """The smallest size among the evaluated nearest test points of test point p (inf: none)."""
    npts = knn.shape[0]
    low = np.inf
    for t in range(knn.shape[1]):
        q = knn[p, t]
        if q >= 0 and q < npts and stamp[q] == i and values[pos[q]] < low:
            low = values[pos[q]]
    return low


@nb.njit(cache=True, _nrt=False)
def _keep(i, p, v, taken, seeds, seed_size):
    """Put seed p (size v) into the slots of row i, of which `taken` are filled: into a free
    one, else in place of the largest if v is below it. Returns the slots filled."""
    m = seeds.shape[1]
    if taken < m:
        seeds[i, taken] = p
        seed_size[i, taken] = v
        return taken + 1
    worst = 0
    for t in range(1, m):
        if seed_size[i, t] > seed_size[i, worst]:
            worst = t
    if v < seed_size[i, worst]:
        seeds[i, worst] = p
        seed_size[i, worst] = v
    return taken


@nb.njit(cache=True, _nrt=False)
def _follows_seed(i, p, low, knn, values, pos, seeds, taken):
    """Whether test point p is one of the first `taken` seeds of row i or its smallest
    neighbour (size `low`) is: p then falls into that seed's basin."""
    for s in range(taken):
        q = seeds[i, s]
        if q == p:
            return True
        for t in range(knn.shape[1]):
            if knn[p, t] == q and values[pos[q]] == low:
                return True
    return False


@nb.njit(cache=True, _nrt=False)
def row_seeds(i, ids, values, count, knn, limit, stamp, pos, low, seeds, seed_size):
    """Up to m = `seeds.shape[1]` seeds of row i into `seeds[i]` (test point ids) and
    `seed_size[i]` (mm): among the evaluated points `ids[:count]` with sizes `values[:count]`
    and size <= `limit`, the m smallest sampled local minima (no evaluated point among their
    nearest test points `knn` is smaller), the first of equal ones in order; slots left over
    take the smallest near-minimal samples (every smaller neighbour within NEAR_TIE of them)
    whose smallest neighbour is not a seed already taken: a valley that falls so gently towards
    a surface edge hides a minimum between its samples that is not one of theirs (the
    compressor at B = 5.08 degrees: the samples fall by 0.001 mm per 1.4 mm towards the edge,
    3 mm from a minimum 0.003 mm below the edge's), and the samples next to a seed follow it
    into its basin, while a minimum further along may lie behind a ridge (docs/MATH.md §6.2).
    `stamp`, `pos` (M,): scratch over all test points, `stamp` never holding i beforehand;
    `low` (M,): scratch, each point's smallest neighbour (found once for both kinds)."""
    for k in range(count):
        stamp[ids[k]] = i
        pos[ids[k]] = k
    taken = np.int64(0)  # not 0: the kernels it is passed to would also compile for the literal
    for k in range(count):
        v = values[k]
        if v <= limit:
            low[k] = _lowest_neighbour(i, ids[k], knn, values, stamp, pos)
            if low[k] >= v:
                taken = _keep(i, ids[k], v, taken, seeds, seed_size)
    m = seeds.shape[1]
    while taken < m:
        pick, size = -1, np.inf
        for k in range(count):
            v = values[k]
            if (v <= limit and v < size and v * (1.0 - NEAR_TIE) <= low[k] < v
                    and not _follows_seed(i, ids[k], low[k], knn, values, pos, seeds, taken)):
                pick, size = k, v
        if pick < 0:
            return
        seeds[i, taken] = ids[pick]
        seed_size[i, taken] = size
        taken += 1
