"""The 4-axis plan of a path: per CC point the allowable size as a function of the table angle B,
the best B and the feasible B intervals for the real cutter; along the path the B chosen by the
shortest path (and, when the config asks for it, `four_axis.greedy_baseline`, the greedy
smoothing of Jun, Lee and Cha (2002) beside it, to compare). The real tool along the program
that is written is checked by `checker.verify`. Part frame, mm, degrees.
(docs/MATH.md §7)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from checker.b_axis import axis_for_b
from checker.config import Config
from checker.four_axis.best_b import BestB, Limited, best_b
from checker.four_axis.orientation import (
    Orientation,
    greedy_smoothing,
    interval_optima,
    shortest_path_orientation,
)


@dataclass(frozen=True)
class Orientations:
    """B per CC point: the CAM's, the best, the chosen (shortest path) and the greedy one (None
    unless the config's `four_axis.greedy_baseline` asks for it)."""

    original: np.ndarray
    best: BestB
    chosen: Orientation
    greedy: Orientation | None


def _take(a: np.ndarray | None, rows: np.ndarray) -> np.ndarray | None:
    return None if a is None else a[rows]


def coarse_config(cfg: Config) -> Config:
    """The engine with one refinement start and step per row: sizes a little above the exact
    ones (upper bounds), for scanning B."""
    engine = cfg.engine.model_copy(update={"refine_seeds": 1, "refine_iterations": 1})
    return cfg.model_copy(update={"engine": engine})


def _facing(contacts, rows: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Which CC points `rows` face their tool axes `axes (M, 3)` (part frame): the others have
    size 0 without a search."""
    return np.einsum("ij,ij->i", contacts.normal[rows], axes) > 1e-12


def _over_b(contacts, sizes):
    """`fn(rows, b_deg) -> (M,)` mm: `sizes(r, axes)` for the CC points `r` that face the tool
    axes `axes (K, 3)` of their table angles (part frame), 0 for the others."""

    def fn(rows: np.ndarray, b_deg: np.ndarray) -> np.ndarray:
        axes = axis_for_b(b_deg)
        out = np.zeros(len(rows))
        facing = _facing(contacts, rows, axes)
        if facing.any():
            out[facing] = sizes(rows[facing], axes[facing])
        return out

    return fn


class OverB:
    """The allowable-cutter engine as a function of the table angle for the CC points
    `contacts` (`cc`, `normal` (N, 3); `surface`, `uv` None when unknown). Each point's last
    size hints the engine's next evaluation of it (the search moves B in small steps; only the
    time depends on the hint); `last (N,)` mm: these hints, shared with another `OverB` of
    the same points (nan: none)."""

    def __init__(self, test_points, part, cutter, contacts, cfg: Config,
                 last: np.ndarray | None = None) -> None:
        self.test_points, self.part, self.cutter, self.cfg = test_points, part, cutter, cfg
        self.contacts = contacts
        self.last = np.full(len(contacts.cc), np.nan) if last is None else last

    def sizes(self, rows: np.ndarray, b_deg: np.ndarray,
              hint: np.ndarray | None = None) -> np.ndarray:
        """The engine's allowable size (M,) mm of CC points `rows` at table angles `b_deg`; 0
        where the point faces away from that axis. `hint (M,)` mm: the sizes expected (e.g.
        upper bounds; default: each point's last size; only the time depends on it)."""
        return self.limited(rows, b_deg, hint).size

    @property
    def tracks(self) -> bool:
        """Whether `near` applies: a NURBS part, the CC points' surfaces and parameters known."""
        c = self.contacts
        return (self.part.mesh is None and c.surface is not None and c.uv is not None
                and bool((np.asarray(c.surface) >= 0).all()))

    def limited(self, rows: np.ndarray, b_deg: np.ndarray,
                hint: np.ndarray | None = None) -> Limited:
        """`sizes(rows, b_deg, hint)` and where they were limited (0 and nowhere where the
        point faces away from the axis)."""
        axes = axis_for_b(b_deg)
        out = Limited.nowhere(len(rows))
        facing = np.flatnonzero(_facing(self.contacts, rows, axes))
        if facing.size:
            from checker.engine import allowable

            r, c = rows[facing], self.contacts
            res = allowable(self.test_points, self.part, self.cutter, c.cc[r], c.normal[r],
                            axes[facing], cc_surface=_take(c.surface, r), cc_uv=_take(c.uv, r),
                            config=self.cfg,
                            hint=self.last[r] if hint is None else hint[facing])
            self.last[r] = res.size
            out.size[facing], out.surface[facing], out.uv[facing] = (
                res.size, res.limiting_surface, res.limiting_uv)
        return out

    def near(self, rows: np.ndarray, b_deg: np.ndarray, surface: np.ndarray,
             uv: np.ndarray) -> np.ndarray:
        """Upper bounds (M,) mm of `sizes(rows, b_deg)` from the points `uv (M, m, 2)` on
        `surface (M, m)` where they were limited at nearby B (`engine.api.sizes_near`)."""
        from checker.engine.api import sizes_near

        c = self.contacts
        return sizes_near(self.test_points, self.part, self.cutter, c.cc[rows], c.normal[rows],
                          axis_for_b(b_deg), surface, uv, cc_surface=c.surface[rows],
                          cc_uv=c.uv[rows], config=self.cfg)


def allowable_over_b(test_points, part, cutter, contacts, cfg: Config):
    """`fn(rows, b_deg) -> sizes` for the best-B search: the engine's allowable size of CC
    point `rows` at table angle `b_deg`; 0 where the point faces away from that axis
    (`OverB.sizes`)."""
    return OverB(test_points, part, cutter, contacts, cfg).sizes


def facing_edges(contacts):
    """`fn(rows, inside, outside) -> (M,)` degrees: the table angle between `inside` and
    `outside` (less than 180 degrees apart) where CC point `rows` turns away from the tool axis
    for good up to `outside` (its size 0 there: `_facing`), nan where there is none. n . axis(B)
    = nz cos B - nx sin B is 0 at atan2(nz, nx) + k 180 degrees."""

    def fn(rows: np.ndarray, inside: np.ndarray, outside: np.ndarray) -> np.ndarray:
        n = contacts.normal[rows]
        zero = np.degrees(np.arctan2(n[:, 2], n[:, 0]))
        lo, hi = np.minimum(inside, outside), np.maximum(inside, outside)
        edge = zero + 180.0 * np.ceil((lo - zero) / 180.0)  # the first zero at or above lo
        away = ~_facing(contacts, rows, axis_for_b(outside))
        return np.where((edge > lo) & (edge < hi) & away, edge, np.nan)

    return fn


def bound_over_b(test_points, part, cutter, contacts, cfg: Config):
    """`fn(rows, b_deg) -> sizes`: upper bounds of `allowable_over_b`'s sizes with the same
    arguments (`engine.api.upper_bounds`), for the best-B search to skip rows that cannot
    matter."""
    from checker.engine.api import upper_bounds

    def sizes(r: np.ndarray, axes: np.ndarray) -> np.ndarray:
        return upper_bounds(test_points, part, cutter, contacts.cc[r], contacts.normal[r], axes,
                            cc_surface=_take(contacts.surface, r), config=cfg)

    return _over_b(contacts, sizes)


def plan_orientations(
    fn,
    coarse_fn,
    b_original: np.ndarray,
    path_length: np.ndarray,
    required: float,
    cfg: Config,
    b_range: tuple[float, float],
    bound_fn=None,
    searched=None,
    tracked=None,
    edge_fn=None,
) -> Orientations:
    """Best B and feasible intervals of every CC point (`fn` exact, `coarse_fn` its cheaper
    upper bound for the scan, `bound_fn` a still cheaper one of that: see `best_b`), then the
    shortest-path orientation inside them (and the greedy one when `greedy_baseline`).
    `b_original` (N,) the CAM's B (nan: none), `path_length` (N,) mm of the step arriving at
    each point, `required` the size the real cutter needs (mm). `searched()`, when given, is
    called once the best-B search is done (before the shortest path's own memory is taken).
    `tracked`: `fn` with its limiting points (`OverB`), for a refinement from fewer evaluations,
    `edge_fn` where the points turn away from the axis (`facing_edges`), for the interval ends
    there (`best_b`)."""
    fa = cfg.four_axis
    n = len(b_original)
    best = best_b(fn, n, b_min=b_range[0], b_max=b_range[1], coarse_step=fa.b_coarse_step,
                  tolerance=fa.b_tolerance, required=required, reference=b_original,
                  coarse_fn=coarse_fn, bound_fn=bound_fn, tracked=tracked, edge_fn=edge_fn)
    if searched is not None:
        searched()
    optima = interval_optima(best.grid, best.samples, best.feasible)
    greedy = greedy_smoothing(optima, best.b_best)[0] if fa.greedy_baseline else None
    extra = np.concatenate(optima) if any(len(o) for o in optima) else None
    chosen = shortest_path_orientation(
        best.feasible, b_original, best.b_best, path_length, b_min=b_range[0], b_max=b_range[1],
        grid_step=fa.dp_b_step, w_change=fa.dp_weight_change, w_original=fa.dp_weight_original,
        max_db_per_mm=fa.max_db_per_mm, extra_candidates=extra,
    )
    return Orientations(b_original, best, chosen, greedy)


def holder_of(cutter) -> dict | None:
    """Shank/holder dimensions of a cutter for `check_holder`, None when it has no holder."""
    if not cutter.holder_diameter or not cutter.stickout:
        return None
    flute = cutter.flute_length or cutter.H or cutter.stickout
    return dict(flute_length=float(flute), stickout=float(cutter.stickout),
                shank_diameter=float(cutter.shank_diameter or cutter.d),
                holder_diameter=float(cutter.holder_diameter),
                holder_length=float(cutter.holder_length or 100.0))
