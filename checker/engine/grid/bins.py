"""Rows with many distinct tool axes (4-axis jobs, the best-B search): bins of nearby axes share
one cell grid, each row keeps its own tool frame.

An axis shared by at least `_OWN_GRID_ROWS` rows gets a grid of its own (exactly the frame of
those rows). The other rows fall into the cells of a fixed lattice on the unit sphere (polar
angle steps of `_BIN_DEG` degrees, azimuth steps of about as much), so that repeated calls reuse
the cached grids; a cell holding a single distinct axis uses that axis (but on the table's
circle, below). In a bin, row i sees a grid point p as `D_i @ p` with `D_i = Q_i Q_bin^T`;
candidates are found in the grid's frame with the search disc widened by the largest sideways
move such a rotation causes over the candidate slab (candidates.py) and then tested exactly in
the row's frame, so the candidate sets, and the results, are those of a grid built for the
row's own axis.

The best-B search of a 4-axis job turns the part about the table's axis (Y): every tool axis
it asks for lies on the circle of axes perpendicular to Y, where the sphere's lattice is a
lattice of table angles B in `_BIN_DEG` steps. The grids of those lattice axes are kept apart
from the other cached grids, each built once for the whole search (`drop_table_grids` frees
them after it: at most 360 / `_BIN_DEG`, about 1.2 MB each for 18k test points), and every row
on the circle is tested in its own frame through D from the lattice grid of its bin, whatever
its B; only an axis that 64 rows share exactly (the scan's columns, the golden section's first
probes) may use an exact grid. As every row is tested in its own frame, the lattice's step
changes the time and the memory, never a result: a coarser one builds and keeps fewer grids
and widens each row's disc by the larger turn to its bin's axis (`benchmarks.bench_engine_axes`
and the 4-axis benchmark measure the choice; CHANGELOG.md has the numbers). A single grid in
the table's frame (z along Y) would also serve every B, but each row's axis is then
perpendicular to the grid's z: a row's region covers a strip across the grid instead of a
disc, which needs a traversal with a third cell dimension; building a grid is cheap against the
evaluations in the sweeps, so the lattice keeps the sweeps' discs tight and costs only memory.
(docs/MATH.md §5)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from checker.engine.grid.candidates import CellGrid, build_grid
from checker.engine.grid.rotations import group_axes, tool_rotation
from checker.geometry.sampling import TestPoints

_BIN_DEG = 8.0  # lattice step on the unit sphere, degrees
_OWN_GRID_ROWS = 64  # rows that share an axis exactly and get a grid of their own
_GRIDS_MAX = 32  # cached grids per set of test points, besides the table lattice's
_TOP_CHUNK = 1 << 21  # (row, hull vertex) products per block in `part_tops`
_HULL_AFTER = 1 << 23  # (row, test point) products beyond which `part_tops` takes the hull


class AxisBin(NamedTuple):
    """Rows that share one cell grid: `rows (B,)`, the bin's unit `axis (3,)` (part frame) and
    its tool frame `rotation (3, 3)`; `relative (B, 3, 3)` each row's tool frame seen from the
    bin's (D), None when every row of the bin has the bin's own frame."""

    rows: np.ndarray
    axis: np.ndarray
    rotation: np.ndarray
    relative: np.ndarray | None


def tool_grid(tp: TestPoints, axis: np.ndarray, Q: np.ndarray | None = None) -> CellGrid:
    """Cell grid of the test points rotated by `Q` (default `tool_rotation(axis)`) into the tool
    frame of the unit `axis` (part frame); cached per axis: kept for the part on the table
    lattice (module docstring), else one of the last `_GRIDS_MAX`."""
    cache = tp.cache("engine.grid.bins")
    key = tuple(np.round(axis, 12).tolist())
    table = cache.setdefault("table", {})
    grids = cache.setdefault("grids", {})
    hit = table.get(key, grids.get(key))
    if hit is None:
        Q = tool_rotation(axis) if Q is None else Q
        hit = build_grid(tp.points @ Q.T)
        if _on_table_lattice(np.asarray(axis, dtype=np.float64)):
            table[key] = hit
        else:
            if len(grids) >= _GRIDS_MAX:
                grids.pop(next(iter(grids)))
            grids[key] = hit
    return hit


def drop_table_grids(tp: TestPoints) -> None:
    """Free the table lattice's grids of `tp` (after a best-B search: the memory goes back)."""
    tp.cache("engine.grid.bins").pop("table", None)


def _on_table_lattice(axis: np.ndarray) -> bool:
    """Whether the unit `axis` (3,) is a lattice axis perpendicular to Y (to 12 decimals)."""
    _, rep = _lattice(axis[None, :])
    return abs(axis[1]) < 1e-12 and bool(np.all(np.round(rep[0] - axis, 12) == 0.0))


def part_tops(tp: TestPoints, Q: np.ndarray) -> np.ndarray:
    """(N,) height of the highest test point in each row's tool frame `Q (N, 3, 3)`, mm: the
    maximum over the vertices of the points' convex hull (cached; all points when the hull is
    flat), or over all points for a few rows before the hull is known (about as fast as the
    hull for ~100 rows, and `allowable` then never imports scipy.spatial, a slow import)."""
    cache = tp.cache("engine.grid.bins")
    ext = cache.get("extreme")
    if ext is None and len(Q) * len(tp.points) <= _HULL_AFTER:
        ext = tp.points
    elif ext is None:
        from scipy.spatial import ConvexHull, QhullError

        try:
            ext = tp.points[ConvexHull(tp.points).vertices]
        except (QhullError, ValueError):
            ext = tp.points
        cache["extreme"] = ext = np.ascontiguousarray(ext)
    top = np.full(len(Q), -np.inf)
    if len(ext):
        step = max(1, _TOP_CHUNK // len(ext))
        for a in range(0, len(Q), step):  # bounded memory: about _TOP_CHUNK products at a time
            top[a:a + step] = (Q[a:a + step, 2, :] @ ext.T).max(axis=1)
    return top


def _lattice(axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lattice cell id (N,) and cell axis (N, 3) of unit axes (N, 3)."""
    h = np.radians(_BIN_DEG)
    theta = np.arccos(np.clip(axes[:, 2], -1.0, 1.0))
    k = np.rint(theta / h)
    tk = k * h
    per_ring = np.maximum(1, 4 * np.ceil(np.pi * np.sin(tk) / (2.0 * h)))
    step = 2.0 * np.pi / per_ring
    j = np.mod(np.rint(np.arctan2(axes[:, 1], axes[:, 0]) / step), per_ring)
    phi = j * step
    rep = np.column_stack([np.sin(tk) * np.cos(phi), np.sin(tk) * np.sin(phi), np.cos(tk)])
    most = 4 * np.ceil(np.pi / (2.0 * h)) + 1
    return (k * most + j).astype(np.int64), rep


def axis_bins(axes: np.ndarray, Q: np.ndarray) -> list[AxisBin]:
    """Bins of rows with unit `axes (N, 3)` and their tool frames `Q (N, 3, 3)`."""
    keys, group = group_axes(axes)
    counts = np.bincount(group, minlength=len(keys))
    cell, rep = _lattice(axes)
    own = counts[group] >= _OWN_GRID_ROWS
    bin_id = np.where(own, group, len(keys) + cell)
    order = np.argsort(bin_id, kind="stable")
    cuts = np.flatnonzero(np.diff(bin_id[order])) + 1
    out = []
    kept = ~own & (np.abs(axes[:, 1]) < 1e-12)  # on the table's circle: the kept lattice grid
    for rows in np.split(order, cuts):
        if rows.size == 0:
            continue
        if (group[rows] == group[rows[0]]).all() and not kept[rows[0]]:
            out.append(AxisBin(rows, axes[rows[0]], Q[rows[0]], None))
        else:
            Qb = tool_rotation(rep[rows[0]])
            out.append(AxisBin(rows, rep[rows[0]], Qb, Q[rows] @ Qb.T))
    return out

