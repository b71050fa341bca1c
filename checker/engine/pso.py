"""The thesis's method as a baseline (chapter 3): particle swarm optimisation over the compound
surface domain, Table 3-3 parameters (64 particles, inertia drawn in [0.1, 0.2], c2 = c3 = 0.5,
stop after 30 iterations without improvement), then a Nelder-Mead polish per CC point. The
particles of all CC points are evaluated together as one vectorised batch on the same kernels.

Compound domain: surface i covers U in [i, i + 1), V in [0, 1], mapped linearly onto its own
(u, v) domain; points outside a trim count as inf."""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from checker.config import EngineConfig
from checker.engine.refine.objective import Objective
from checker.engine.refine.row_best import RowBest
from checker.engine.sizes import RowFrame
from checker.part import Part


def _to_surface(part: Part, X: np.ndarray):
    """Compound coordinates (K, 2) -> (surface id (K,), u (K,), v (K,))."""
    ns = len(part.surfaces)
    sid = np.clip(np.floor(X[:, 0]).astype(np.int64), 0, ns - 1)
    dom = part.domains
    fu = np.clip(X[:, 0] - sid, 0.0, 1.0)
    fv = np.clip(X[:, 1], 0.0, 1.0)
    u = dom[sid, 0, 0] + fu * (dom[sid, 0, 1] - dom[sid, 0, 0])
    v = dom[sid, 1, 0] + fv * (dom[sid, 1, 1] - dom[sid, 1, 0])
    return sid, u, v


def pso_search(part: Part, cutter, frame: RowFrame, Q: np.ndarray, rng: np.random.Generator,
               cfg: EngineConfig) -> RowBest:
    """PSO + Nelder-Mead for every row of `frame` (tool frames `Q (N, 3, 3)`, one per row);
    the rows' best like the exact engine's."""
    obj = Objective(part, cutter, frame, Q)
    n, npart = len(frame.cc), cfg.pso_particles
    ns = len(part.surfaces)
    hi = np.array([float(ns), 1.0])
    vmax = cfg.pso_vmax * np.array([1.0, 1.0])
    X = rng.random((n, npart, 2)) * hi
    V = np.zeros_like(X)
    rows = np.repeat(np.arange(n), npart)

    def f_of(Xf: np.ndarray, r: np.ndarray) -> np.ndarray:
        sid, u, v = _to_surface(part, Xf)
        return obj.exact(r, sid, u, v, order=1).size

    F = f_of(X.reshape(-1, 2), rows).reshape(n, npart)
    pbest, pval = X.copy(), F.copy()
    g = np.argmin(pval, axis=1)
    gbest, gval = pbest[np.arange(n), g].copy(), pval[np.arange(n), g].copy()
    evals = np.full(n, npart, dtype=np.int64)
    still = np.zeros(n, dtype=np.int64)
    active = np.ones(n, dtype=bool)
    lo_w, hi_w = cfg.pso_inertia
    for _ in range(cfg.pso_max_iterations):
        a = np.flatnonzero(active)
        if a.size == 0:
            break
        w = rng.uniform(lo_w, hi_w, size=(a.size, 1, 1))
        r1, r2 = rng.random((a.size, npart, 2)), rng.random((a.size, npart, 2))
        V[a] = (w * V[a] + cfg.pso_c2 * r1 * (pbest[a] - X[a])
                + cfg.pso_c3 * r2 * (gbest[a, None] - X[a]))
        V[a] = np.clip(V[a], -vmax, vmax)
        X[a] = np.clip(X[a] + V[a], 0.0, hi - 1e-12)
        Fa = f_of(X[a].reshape(-1, 2), np.repeat(a, npart)).reshape(a.size, npart)
        evals[a] += npart
        better = Fa < pval[a]
        pb, pv = pbest[a], pval[a]
        pb[better], pv[better] = X[a][better], Fa[better]
        pbest[a], pval[a] = pb, pv
        k = np.argmin(pv, axis=1)
        cand = pv[np.arange(a.size), k]
        improved = cand < gval[a]
        gi = a[improved]
        gbest[gi], gval[gi] = pb[improved, k[improved]], cand[improved]
        still[a] = np.where(improved, 0, still[a] + 1)
        active[a] = still[a] < cfg.pso_repeat
    size = gval.copy()
    X_final = gbest.copy()
    for i in np.flatnonzero(np.isfinite(gval)):  # the thesis's scalar local polish, per point
        r = np.array([i])
        res = minimize(lambda x, r=r: float(f_of(np.clip(x, 0.0, hi - 1e-12)[None], r)[0]),
                       gbest[i], method="Nelder-Mead",
                       options={"xatol": 1e-9, "fatol": 1e-9, "maxiter": 200})
        evals[i] += res.nfev
        if res.fun < size[i]:
            size[i], X_final[i] = res.fun, np.clip(res.x, 0.0, hi - 1e-12)
    sid, u, v = _to_surface(part, X_final)
    pts = obj.exact(np.arange(n), sid, u, v, order=1).point
    found = np.isfinite(size)
    pts[~found] = np.nan
    sid = np.where(found, sid, -1)
    uv = np.where(found[:, None], np.column_stack([u, v]), np.nan)
    return RowBest(size, pts, sid, uv, evals)
