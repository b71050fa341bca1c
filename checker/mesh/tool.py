"""The real tool as a union of convex solids of revolution ("pieces") for the exact mesh depth.

Tool frame: tip at the origin, axis +z; a point's radial distance from the axis is r and its
height above the tip is h (mm). Each piece is `core (+) ball(rho)`: the core K is the solid of
revolution of a convex polygon in the (r >= 0, h) half-plane that has an edge (or a vertex) on
the axis, so the solid is convex; the polygon may be degenerate (a segment on the axis: a ball
end-mill's core). Vertices are stored counter-clockwise in (r, h) (r to the right, h up).

Pieces of a `Cutter` (`tool_pieces`):
- kind 0, the body: exactly `cutter.core` (checker/cutter_core.py, `Core.profile`) grown by the
  corner radius r. The core's profile is the wedge with its corner at C = (R, h_o), h_o = R tan(psi)
  + r sec(psi): its lower side goes from C to the axis at (0, r sec(psi)) (the bottom offset by r),
  its outer side leaves C upwards with taper theta (the side offset by r), its top is at `top`.
  flat: the rectangle [0, R] x [0, top], rho = 0; ball: the axis segment from h = r to top, rho = r;
  bull-nose: [0, R] x [r, top], rho = r; APT: the wedge; tapered ball: the cone from (0, r). `top`
  is the flute length when known, else `H` when > 0, else unbounded (`UNBOUNDED` mm; the depth
  kernel clips it per pose just above the mesh, which changes no answer). With rho > 0 the body's
  top is the core's top grown by rho: a rounded cap reaching rho above `top` (into the shank's span:
  conservative). With psi > 0 and r > 0 the grown core is rounded where the real tip is sharp, short
  of it by r (sec(psi) - 1) along the axis (as in contact.py).
- kind 1, the shank: the cylinder of radius shank_diameter / 2 from the flute length to the
  stickout, rho = 0; present when `flute_length`, `shank_diameter` and `stickout` are known.
- kind 2, the holder: the cylinder of radius holder_diameter / 2 from the stickout to
  stickout + holder_length, rho = 0; present when `with_holder` and `stickout`,
  `holder_diameter` and `holder_length` are known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

MAXV = 8           # profile vertices per piece at most (the pieces here need 4)
UNBOUNDED = 1e6    # mm: the top of a body whose length is not known
BODY, SHANK, HOLDER = 0, 1, 2


@dataclass(frozen=True)
class ToolPieces:
    """The pieces of one tool, tool frame, mm. `prof (P, MAXV, 2)` half-profile vertices (r, h)
    counter-clockwise (rows past `nprof[p]` unused), `nprof (P,)` vertex counts, `rho (P,)` the
    ball radius each core is grown by, `kind (P,)` 0 body, 1 shank, 2 holder."""

    prof: np.ndarray
    nprof: np.ndarray
    rho: np.ndarray
    kind: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)


@nb.njit(cache=True)
def drop_repeats(pts: np.ndarray, k: int, tol: float) -> int:
    """Compact the closed polygon pts[:k] (2-D) in place: a vertex within `tol` (mm, in each
    coordinate) of the one before it is dropped, also across the wrap; return the count left."""
    q = 0
    for i in range(k):
        if q > 0 and abs(pts[i, 0] - pts[q - 1, 0]) <= tol and \
                abs(pts[i, 1] - pts[q - 1, 1]) <= tol:
            continue
        pts[q, 0], pts[q, 1] = pts[i, 0], pts[i, 1]
        q += 1
    while q > 1 and abs(pts[q - 1, 0] - pts[0, 0]) <= tol and \
            abs(pts[q - 1, 1] - pts[0, 1]) <= tol:
        q -= 1
    return q


@nb.njit(cache=True)
def _compact(prof: np.ndarray, nprof: np.ndarray) -> None:
    """Drop the repeated vertices of each closed polygon prof[i, :nprof[i]] in place (within
    1e-12 mm), nprof updated."""
    for i in range(prof.shape[0]):
        nprof[i] = drop_repeats(prof[i], nprof[i], 1e-12)


def body_profiles(core, top: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body pieces of the cutters whose cores are `core` (a `checker.cutter_core.Core`, r and
    R scalars or (N,) arrays: `Cutter.core`, `Cutter.cores(sizes)`) with the core's top at
    `top` (mm): (prof (N, MAXV, 2), nprof (N,), rho (N,) the radius each core is grown by);
    a ball's core is a segment on the axis (2 vertices)."""
    verts, rho = core.profile(top)
    prof = np.zeros((len(verts), MAXV, 2))
    prof[:, :4] = verts
    nprof = np.full(len(verts), 4, dtype=np.int64)
    _compact(prof, nprof)
    return prof, nprof, rho


def _cylinder(radius: float, h0: float, h1: float) -> np.ndarray:
    return np.array([[0.0, h0], [radius, h0], [radius, h1], [0.0, h1]])


def body_top(cutter) -> float:
    """Top of the body's core (mm above the tip): the flute length, else H > 0, else
    UNBOUNDED."""
    if cutter.flute_length is not None and cutter.flute_length > 0.0:
        return float(cutter.flute_length)
    if cutter.H > 0.0:
        return float(cutter.H)
    return UNBOUNDED


def tool_pieces(cutter, *, with_holder: bool) -> ToolPieces:
    """The pieces of `cutter` (a `checker.cutter.Cutter`): its body, its shank when known and,
    with `with_holder`, its holder when known (module docstring)."""
    body, nbody, grow = body_profiles(cutter.core, body_top(cutter))
    profs, rhos, kinds = [body[0, : nbody[0]].copy()], [float(grow[0])], [BODY]
    L, S = cutter.flute_length, cutter.stickout
    if L is not None and S is not None and cutter.shank_diameter and S > L:
        profs.append(_cylinder(0.5 * float(cutter.shank_diameter), float(L), float(S)))
        rhos.append(0.0)
        kinds.append(SHANK)
    if (with_holder and S is not None and cutter.holder_diameter and cutter.holder_length
            and cutter.holder_length > 0.0):
        profs.append(_cylinder(0.5 * float(cutter.holder_diameter), float(S),
                               float(S) + float(cutter.holder_length)))
        rhos.append(0.0)
        kinds.append(HOLDER)
    prof = np.zeros((len(profs), MAXV, 2))
    nprof = np.zeros(len(profs), dtype=np.int64)
    for p, pr in enumerate(profs):
        prof[p, : len(pr)] = pr
        nprof[p] = len(pr)
    return ToolPieces(prof, nprof, np.array(rhos, dtype=np.float64),
                      np.array(kinds, dtype=np.int64))
