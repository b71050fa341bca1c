"""Rotary wrap modes: from a continuous B (degrees, unwrapped along the path) to the B words a
control understands, and back.

- Rollover modes (``shortest``, ``signed``) never need a retract: words are the position modulo
  360 (``signed``: the sign of the word gives the direction of rotation, ``-0.`` included), and
  every block turns less than MAX_STEP degrees so the shorter way is the intended way.
- Range modes (``limited``, ``0_360``, ``-180_180``): the table moves by the difference of words,
  so a word is ``w + 360 n`` inside the closed range; where the branch ``n`` must change between
  two points the post retracts, turns the table a full turn back and re-enters.
"""

from __future__ import annotations

import numpy as np

from checker.errors import raise_at_first

#: the largest B change in one block (degrees); longer moves are split so "shortest" is unambiguous
MAX_STEP = 179.0


def rollover_words(w: np.ndarray, mode: str, decimals: int) -> np.ndarray:
    """Words ``(N,)`` for a rollover axis from continuous words ``w (N,)`` degrees, rounded to
    ``decimals``. ``signed`` words are negative (``-0.0`` included) when the block turns the
    negative way."""
    w = np.asarray(w, dtype=float)
    pos = np.round(np.mod(w, 360.0), decimals)
    pos[pos >= 360.0] -= 360.0
    if mode == "shortest":
        return pos
    negative = np.diff(w, prepend=w[:1]) < 0.0
    return np.where(negative, -pos, pos)  # -pos of 0.0 is -0.0: "B-0." turns the negative way


def unroll_rollover(words: np.ndarray, mode: str, start: float = 0.0) -> np.ndarray:
    """Continuous table position ``(N,)`` degrees a rollover control reaches for ``words (N,)``,
    starting from ``start``: the shorter way (``shortest``) or the way the sign says
    (``signed``)."""
    words = np.asarray(words, dtype=float)
    target = np.abs(words) if mode == "signed" else words
    prev = np.concatenate([[np.mod(start, 360.0)], target[:-1]])
    delta = np.mod(target - prev, 360.0)  # in [0, 360): the positive way
    if mode == "signed":
        step = np.where(np.signbit(words) & (delta > 0.0), delta - 360.0, delta)
    else:
        step = np.where(delta > 180.0, delta - 360.0, delta)
    return start + np.cumsum(step)


def range_branches(
    w: np.ndarray, lo: float, hi: float, lines: np.ndarray | None = None, path: str | None = None
) -> np.ndarray:
    """Branch ``n (N,)`` so that ``w + 360 n`` lies in ``[lo, hi]``: each run keeps one branch as
    long as it can, a new run starts where the path leaves the range. ``w (N,)`` continuous words
    in degrees; a point that fits no branch is a travel-limit error naming its source ``path``
    and line."""
    w = np.asarray(w, dtype=float)
    n_lo = np.ceil((lo - w) / 360.0 - 1e-12)
    n_hi = np.floor((hi - w) / 360.0 + 1e-12)
    raise_at_first(n_lo > n_hi, lines, lambda k: (
        f"B = {w[k]:.4f} deg cannot be reached: expected a B word in [{lo:g}, {hi:g}] "
        f"(modulo 360), found none"), path=path, code="travel")
    branch = np.empty(w.size, dtype=int)
    start = 0
    while start < w.size:
        best_n, best_end = 0, start
        # the branch that lasts longest; on a tie, the word nearest 0
        candidates = sorted(
            range(int(n_lo[start]), int(n_hi[start]) + 1), key=lambda n: abs(w[start] + 360.0 * n)
        )
        for n in candidates:
            inside = (w[start:] + 360.0 * n >= lo - 1e-9) & (w[start:] + 360.0 * n <= hi + 1e-9)
            out = np.flatnonzero(~inside)
            end = start + (int(out[0]) if out.size else w.size - start)
            if end > best_end:
                best_n, best_end = n, end
        branch[start:best_end] = best_n
        start = best_end
    return branch
