"""Surfaces as a few flat numpy arrays and back: how the contained STEP/IGES reader
(`checker.sandbox`) hands its faces to the parent process without pickle.

Arrays: `head (N, 8) int64` per surface (degree_u, degree_v, poles_u, poles_v, flip, rational,
outer loops, hole loops); `kinds (N,)` str; `knots_u`, `knots_v` concatenated; `poles (P, 3)`
mm and `weights (P,)` concatenated u-major; `loop_sizes (L,)` and `loops (K, 2)` (u, v) of
every trim loop, a surface's outer loops before its holes."""

from __future__ import annotations

import numpy as np

from checker.geometry.trims import UVTrim
from checker.part import Surface


def pack_surfaces(surfaces: list[Surface]) -> dict[str, np.ndarray]:
    """The arrays of `surfaces` (trims must be `UVTrim` or None)."""
    head, loops = [], []
    for s in surfaces:
        outer = s.trim.outer if s.trim is not None else []
        holes = s.trim.holes if s.trim is not None else []
        nu, nv = s.ctrlpts.shape[:2]
        head.append((s.degree_u, s.degree_v, nu, nv, s.flip, s.weights is not None,
                     len(outer), len(holes)))
        loops += [np.asarray(lp, dtype=np.float64).reshape(-1, 2) for lp in [*outer, *holes]]
    w = [np.ones(s.ctrlpts.shape[:2]) if s.weights is None else s.weights for s in surfaces]
    return {
        "head": np.array(head, dtype=np.int64).reshape(-1, 8),
        "kinds": np.array([s.kind for s in surfaces], dtype=str),
        "knots_u": np.concatenate([s.knots_u for s in surfaces] + [np.zeros(0)]),
        "knots_v": np.concatenate([s.knots_v for s in surfaces] + [np.zeros(0)]),
        "poles": np.concatenate([s.ctrlpts.reshape(-1, 3) for s in surfaces] + [np.zeros((0, 3))]),
        "weights": np.concatenate([x.ravel() for x in w] + [np.zeros(0)]),
        "loop_sizes": np.array([len(lp) for lp in loops], dtype=np.int64),
        "loops": np.concatenate(loops + [np.zeros((0, 2))]),
    }


def unpack_surfaces(a: dict[str, np.ndarray]) -> list[Surface]:
    """The surfaces of `pack_surfaces` arrays (named `face_<id>_<kind>`)."""
    head = a["head"]
    ku_at = np.cumsum([0] + [nu + p + 1 for p, _, nu, *_ in head])
    kv_at = np.cumsum([0] + [nv + q + 1 for _, q, _, nv, *_ in head])
    pole_at = np.cumsum([0] + [nu * nv for _, _, nu, nv, *_ in head])
    loops = np.split(a["loops"], np.cumsum(a["loop_sizes"])[:-1]) if len(a["loop_sizes"]) else []
    loop_at = np.cumsum([0] + [h[6] + h[7] for h in head])
    out = []
    for i, (p, q, nu, nv, flip, rational, n_outer, n_holes) in enumerate(head):
        mine = loops[loop_at[i]:loop_at[i + 1]]
        trim = UVTrim(mine[:n_outer], mine[n_outer:]) if n_outer + n_holes else None
        out.append(Surface(
            id=i, name=f"face_{i}_{a['kinds'][i]}", kind=str(a["kinds"][i]),
            degree_u=int(p), degree_v=int(q),
            knots_u=a["knots_u"][ku_at[i]:ku_at[i + 1]],
            knots_v=a["knots_v"][kv_at[i]:kv_at[i + 1]],
            ctrlpts=a["poles"][pole_at[i]:pole_at[i + 1]].reshape(nu, nv, 3),
            weights=a["weights"][pole_at[i]:pole_at[i + 1]].reshape(nu, nv) if rational else None,
            trim=trim, flip=bool(flip)))
    return out
