"""The allowable-cutter advice at each CC point: does the real cutter fit there, and if not,
is the limit near the contact or elsewhere (docs/MATH.md §8). Advice, never a verdict: the
one verdict rule is `checker.verdict`, applied to the real tool at its real pose.

Labels (`ADVICE`): `fits` (the real size is at most the allowable size plus the tolerance);
`too_large_near` (larger, and the limiting point is on the CC point's own surface within the
neighbourhood: the surface's curvature there limits the cutter); `too_large_far` (larger, and
the limit is another surface or farther away); `inaccessible` (the normal faces away from the
tool or the allowable size is 0)."""

from __future__ import annotations

import numpy as np

ADVICE: tuple[str, ...] = ("fits", "too_large_near", "too_large_far", "inaccessible")


def advice(size: np.ndarray, real_size: float, tolerance: float, faces_away: np.ndarray,
           same_surface: np.ndarray, distance: np.ndarray, neighbourhood: float) -> np.ndarray:
    """(N,) strings of ADVICE from the allowable `size` (mm), the `real_size` and `tolerance`
    (mm), where the normal `faces_away` from the tool, whether the limiting point is on the CC
    point's `same_surface` and its `distance` from the CC point (mm) against `neighbourhood`
    (mm)."""
    out = np.full(size.shape, "fits", dtype=object)
    too_big = real_size > size + tolerance
    local = same_surface & (distance <= neighbourhood)
    out[too_big & local] = "too_large_near"
    out[too_big & ~local] = "too_large_far"
    out[faces_away | (size <= 0.0)] = "inaccessible"
    return out.astype(str)
