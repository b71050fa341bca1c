"""Seeds of the local refinement for one CC row: the sampled local minima of the imaginary size
among the row's evaluated test points (numba)."""

from __future__ import annotations

import numba as nb


@nb.njit(cache=True)
def row_seeds(i, ids, values, count, knn, limit, stamp, pos, seeds, seed_size):
    """Up to m = `seeds.shape[1]` seeds of row i into `seeds[i]` (test point ids) and
    `seed_size[i]` (mm): among the evaluated points `ids[:count]` with sizes `values[:count]`,
    those with size <= `limit` that are sampled local minima (no evaluated point among their
    nearest test points `knn` is smaller), the m smallest, the first of equal ones in order.
    `stamp`, `pos` (M,): scratch over all test points, `stamp` never holding i beforehand."""
    m = seeds.shape[1]
    npts = knn.shape[0]
    for k in range(count):
        stamp[ids[k]] = i
        pos[ids[k]] = k
    taken = 0
    for k in range(count):
        v = values[k]
        if v > limit:
            continue
        p = ids[k]
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
