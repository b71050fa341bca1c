"""Sound bounds on where a test point with a small imaginary size can lie, per CC row.

Derivation (tool frame, tool axis +z, mm; the cutter's part is `Cutter.size_reach`). R-family
(flat, bull-nose, APT; size s = R, corner radius r, bottom angle psi, taper theta): the size-s
cutter has its axis through `O_h + s e` (O = Pcc + r n) and profile radius at most `s + kappa` at
every height the part reaches, with `kappa = r sec(theta) + max(0, z_top - O_z) max(tan(theta),
0)`. Ball family (ball, tapered ball; size s = r): axis through `Pcc_h + s n_h`, radius at most `s
sec(theta) + kappa`, `kappa = max(0, z_top - Pcc_z) max(tan(theta), 0)`. Both are a moving disc
`|P_h - c0 - s w| <= a s + kappa` with `a >= |w|`, so the discs are nested in s: a point with R(P)
<= s lies in disc(s). The tip `z0 - t s` only sinks as s grows (t = tan(psi), resp. 1 - n_z), so
such a point also lies between `z0 - t s` and `z0 + H` (H the cutter length; the part top when the
length is unknown). Tip contact (`Cutter.contact_case`: psi > 0, n_z > cos(psi)): the axis passes
through Pcc, the disc is fixed (w = 0). Vertical normal without a direction e (worst case over e, R
= (|d| - k) / 2): |d| <= 2 s + k, the disc about O_h with a = 2, w = 0.
(docs/MATH.md §5.1)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class FamilyBounds:
    """Per-row bound parameters, tool frame, mm: disc centre `c0 + s w`, radius `a s + kappa`;
    tip height `z0 - t s`; cutter length `length` (inf when unknown); `z_top` highest point that
    a cutter of any size <= s can reach (min of part top and z0 + length)."""

    c0: np.ndarray
    w: np.ndarray
    a: np.ndarray
    kappa: np.ndarray
    z0: np.ndarray
    t: np.ndarray
    length: float
    z_top: np.ndarray
    cc: np.ndarray | None = None
    n: np.ndarray | None = None
    sin_theta: float = 0.0

    def centre(self, s: np.ndarray) -> np.ndarray:
        """(N, 2) disc centres for sizes s (N,)."""
        return self.c0 + np.where(np.isfinite(s), s, 0.0)[:, None] * self.w

    def radius(self, s: np.ndarray) -> np.ndarray:
        """(N,) disc radii for sizes s (N,)."""
        return self.a * s + self.kappa

    def z_low(self, s: np.ndarray) -> np.ndarray:
        """(N,) lowest height a cutter of size <= s reaches (its tip)."""
        return self.z0 - self.t * s

    def lower_ball(self, s: np.ndarray, slack: float) -> tuple[np.ndarray, np.ndarray]:
        """Ball family: below the sphere/taper boundary `zeq (N,)` the cutter of size s is its
        sphere (centre cc + s n, radius s): `sphere (N, 4)` grown by `slack`. Other families:
        zeq = -inf (no extra condition)."""
        n = len(s)
        sphere = np.zeros((n, 4))
        zeq = np.full(n, -np.inf)
        if self.cc is not None:
            sf = np.where(np.isfinite(s), s, 0.0)
            sphere[:, :3] = self.cc + sf[:, None] * self.n
            sphere[:, 3] = sf + slack
            zeq = np.where(np.isfinite(s), sphere[:, 2] - sf * self.sin_theta - slack, -np.inf)
        return sphere, zeq

    def take(self, rows: np.ndarray) -> FamilyBounds:
        """The bounds of a subset of rows."""
        pick = (lambda a: None if a is None else a[rows])  # noqa: E731
        return FamilyBounds(self.c0[rows], self.w[rows], self.a[rows], self.kappa[rows],
                            self.z0[rows], self.t[rows], self.length, self.z_top[rows],
                            pick(self.cc), pick(self.n), self.sin_theta)


def cutter_length(cutter) -> float:
    """Cutting length H in mm, inf when the cutter gives none."""
    h = float(getattr(cutter, "H", 0.0) or 0.0)
    return h if h > 0.0 else np.inf


def family_bounds(cutter, cc: np.ndarray, n: np.ndarray, e: np.ndarray, degenerate: np.ndarray,
                  part_top: float | np.ndarray) -> FamilyBounds:
    """Bounds for N rows: `cc`, unit `n` (N, 3) and unit horizontal `e` (N, 3), tool frame;
    `degenerate (N,)` rows without a direction e; `part_top` the highest test point (mm), one
    or (N,) per row in its own tool frame. The family's geometry is the cutter's answer
    (`Cutter.size_reach`); this adds the heights the part and the cutter's length allow."""
    reach = cutter.size_reach(cc, n, e, degenerate)
    length = cutter_length(cutter)
    z_top = np.minimum(reach.z0 + length, part_top)
    kappa = reach.side + np.maximum(z_top - reach.base, 0.0) * reach.flare
    if reach.sphere:
        return FamilyBounds(reach.c0, reach.w, reach.a, kappa, reach.z0, reach.t, length, z_top,
                            cc, n, reach.sin_theta)
    return FamilyBounds(reach.c0, reach.w, reach.a, kappa, reach.z0, reach.t, length, z_top)
