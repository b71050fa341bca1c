"""Verdicts of the real cutter at each CC point from the allowable size and the limiting point.
(docs/MATH.md §8)"""

from __future__ import annotations

import numpy as np


def verdicts(size: np.ndarray, real_size: float, tolerance: float, faces_away: np.ndarray,
             same_surface: np.ndarray, distance: np.ndarray, neighbourhood: float) -> np.ndarray:
    """(N,) strings: `inaccessible` where the normal faces away from the tool or the allowable
    size is 0; else, when the real size exceeds `size + tolerance` (mm), `gouge` if the limiting
    point is on the CC point's own surface within `neighbourhood` mm of it (curvature), else
    `interference` (another surface, or far away); `ok` otherwise."""
    out = np.full(size.shape, "ok", dtype=object)
    too_big = real_size > size + tolerance
    local = same_surface & (distance <= neighbourhood)
    out[too_big & local] = "gouge"
    out[too_big & ~local] = "interference"
    out[faces_away | (size <= 0.0)] = "inaccessible"
    return out.astype(str)
