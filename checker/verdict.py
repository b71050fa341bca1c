"""The one verdict rule. A checked pose (or move) is a finding when the real tool at its real
pose penetrates the part by more than the job's tolerance:
- `crash`: a rapid move in which any part of the tool touches the part (penetration above the
  tolerance); a canned cycle's rapid back out of its hole retraces the feed in, and is judged
  as a feed move;
- `holder`: the shank or the holder penetrates (a feed move);
- `gouge`: the cutter's body penetrates near the contact, on the surface being cut (within the
  gouge neighbourhood of the contact point, on its surface where the part has surfaces);
- `interference`: the cutter's body penetrates anywhere else.
A penetration of at most the tolerance is `within_tolerance` (counted apart, never a finding).
Where nothing penetrates, the pose is `ok`; `inaccessible` marks a cutting pose whose contact
point the cutter cannot touch (advice, never a finding). The allowable cutter and the margin
are advice about a pose and never decide a verdict.
Against the stock (the material still there when the move is made) and the fixtures, the same
rule with what may be touched: the cutter's body cuts stock at feed (that is machining, never a
finding); a rapid that removes stock beyond the tolerance is a `crash`, the shank or the holder
removing stock at feed a `holder` finding; any piece of the tool in a fixture beyond the
tolerance is a `crash` (`decide_stock`, `decide_fixture`).
Against the design, the machined part (the stock at the end) is a `gouge` where it is cut below
the part's surface beyond the tolerance by more than the simulation's error bound there
(`decide_machined`): a gouge as the machine leaves it, counted apart from the poses' verdicts.
Between the machine's own solids, the tool and the work, closer than the stated clearance is a
`machine` finding (`decide_machine`).
(docs/MATH.md §8, §14, §15, §16)"""

from __future__ import annotations

import numpy as np

# the order is the stores' per-point code (checker.store): new verdicts go at the end
VERDICTS: tuple[str, ...] = ("ok", "gouge", "interference", "holder", "inaccessible",
                             "within_tolerance", "crash", "machine")
FINDINGS: tuple[str, ...] = ("gouge", "interference", "holder", "crash", "machine")
BODY, SHANK, HOLDER = 0, 1, 2  # tool pieces, as `checker.mesh.tool` numbers them


def decide(depth: np.ndarray, piece: np.ndarray, rapid: np.ndarray, near_contact: np.ndarray,
           tolerance: np.ndarray | float, inaccessible: np.ndarray | None = None) -> np.ndarray:
    """Verdicts (N,) (strings of VERDICTS) from, per pose or move: the deepest penetration of
    the real tool `depth` (mm; <= 0: clear), the tool `piece` that reaches it (BODY, SHANK,
    HOLDER), whether the move is a `rapid`, whether the deepest point is `near_contact` (on the
    surface being cut, near the contact), the `tolerance` (mm), and optionally where the
    contact cannot be touched at all (`inaccessible`)."""
    depth = np.asarray(depth, dtype=float)
    tol = np.broadcast_to(np.asarray(tolerance, dtype=float), depth.shape)
    out = np.full(depth.shape, "ok", dtype=object)
    if inaccessible is not None:
        out[np.asarray(inaccessible, bool) & ~(depth > 0.0)] = "inaccessible"
    out[depth > 0.0] = "within_tolerance"
    beyond = depth > tol
    body = np.asarray(piece) == BODY
    near = np.asarray(near_contact, bool)
    out[beyond & body & near] = "gouge"
    out[beyond & body & ~near] = "interference"
    out[beyond & ~body] = "holder"
    out[beyond & np.asarray(rapid, bool)] = "crash"
    return out


def decide_stock(thickness: np.ndarray, rapid: np.ndarray,
                 tolerance: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Verdicts (N,) and the piece (N,) that decides each, per pose or move, from the stock's
    largest thickness removed along one ray by each piece `thickness (N, 3)` (mm; BODY, SHANK,
    HOLDER), whether the move is a `rapid` and the `tolerance` (mm)."""
    thickness = np.asarray(thickness, dtype=float)
    tol = np.broadcast_to(np.asarray(tolerance, dtype=float), thickness.shape[:1])
    rapid = np.asarray(rapid, bool)
    out = np.full(thickness.shape[:1], "ok", dtype=object)
    piece = np.full(thickness.shape[:1], -1, dtype=np.int64)
    holder = thickness[:, SHANK:].max(axis=1) > tol
    piece[holder] = SHANK + np.argmax(thickness[holder, SHANK:], axis=1)
    out[holder] = "holder"
    crash = rapid & (thickness.max(axis=1) > tol)
    piece[crash] = np.argmax(thickness[crash], axis=1)
    out[crash] = "crash"
    touched = ~holder & ~crash & (thickness[:, SHANK:].max(axis=1) > 0.0)
    out[touched | (rapid & ~crash & (thickness.max(axis=1) > 0.0))] = "within_tolerance"
    return out, piece


def decide_fixture(depth: np.ndarray, tolerance: np.ndarray | float) -> np.ndarray:
    """Verdicts (N,) of the tool against a fixture from its deepest penetration `depth` (mm;
    <= 0: clear): beyond the `tolerance` a `crash`, whatever the move."""
    depth = np.asarray(depth, dtype=float)
    tol = np.broadcast_to(np.asarray(tolerance, dtype=float), depth.shape)
    out = np.full(depth.shape, "ok", dtype=object)
    out[depth > 0.0] = "within_tolerance"
    out[depth > tol] = "crash"
    return out


def decide_machined(overcut: np.ndarray, tolerance: np.ndarray | float,
                    bound: np.ndarray | float) -> np.ndarray:
    """Verdicts (N,) of the machined part at its measuring points from the depth each is
    over-cut `overcut` (mm, <= 0: not cut below the design), the `tolerance` (mm) and the
    simulation's error `bound` there (mm): a `gouge` beyond tolerance + bound, a smaller cut
    `within_tolerance`."""
    overcut = np.asarray(overcut, dtype=float)
    limit = np.broadcast_to(np.asarray(tolerance, dtype=float) + np.asarray(bound, dtype=float),
                            overcut.shape)
    out = np.full(overcut.shape, "ok", dtype=object)
    out[overcut > 0.0] = "within_tolerance"
    out[overcut > limit] = "gouge"
    return out


def decide_machine(distance: np.ndarray, clearance: np.ndarray | float) -> np.ndarray:
    """Verdicts (N,) of two solids of the machine check (the machine's components, the tool,
    the work) from their least `distance` (mm; < 0: penetration): closer than the `clearance`
    (mm) a `machine` finding, whatever the move (docs/MATH.md §16)."""
    distance = np.asarray(distance, dtype=float)
    out = np.full(distance.shape, "ok", dtype=object)
    out[distance < np.broadcast_to(np.asarray(clearance, dtype=float), distance.shape)] = "machine"
    return out


def is_finding(verdicts: np.ndarray) -> np.ndarray:
    """(N,) bool: the verdicts that are findings."""
    return np.isin(np.asarray(verdicts, dtype=object), FINDINGS)


def status(verdicts) -> str:
    """'findings' when any verdict is a finding, else 'ok': the one status that the exit code,
    the summary, the store, the report and the service reply all show."""
    return "findings" if bool(is_finding(np.asarray(list(verdicts), dtype=object)).any()) else "ok"
