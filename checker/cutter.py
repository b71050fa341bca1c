"""The cutter model of docs/MATH.md §2 (flat, ball, bull-nose, APT, tapered ball) and its parsers.

A `Cutter` is plain data (mm, radians) plus the family's interface, which every algorithm asks
instead of reading `kind`, `psi`, `theta` or `r` (OpenCAMLib's lesson: each algorithm is written
once against the cutter): the contact case of a normal (`contact_case`, decided by
`checker.kernels.contact_case` with its one slack), the imaginary-cutter size (compiled in
`checker.kernels`, on `kernel_params`), the tool tip from a contact and the line it moves on
with the size (`size_reach`), the profile (`profile_radius`, `profile_slope`), the solid as a
core (`core`, `cores`), the curvature limit at the CC point (`curvature_limit`) and the signed
distance. Tool frame: tip at the origin, axis +z. (docs/MATH.md §2, §3)

Statements: APT `CUTTER/d`, `CUTTER/d,r`, `CUTTER/d,r,e,f,alpha,beta,h` (ISO 4343; angles in
degrees) and Siemens NX `TLDATA/MILL,D,R1,L,B,A[,XC,YC[,R2,X2,Y2]]` (D diameter, R1 lower corner
radius, L length, B taper angle, A tip angle, XC/YC lower corner centre; the upper corner R2 is
validated and ignored: it rounds the top of the flutes, outside the cutting model).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

import numpy as np

from checker.cutter_core import Core
from checker.cutter_core import signed_distance as core_signed_distance
from checker.errors import PathcheckError
from checker.units import MM_PER_INCH

KINDS = ("flat", "ball", "bullnose", "apt", "tapered_ball")
BALL_FAMILY = ("ball", "tapered_ball")
_ANGLE_DIGITS = 12  # angles are kept as radians(round(degrees, 12)) so CUTTER/ text round-trips


def _kernels():
    """`checker.kernels` (a layer below the cutter: it imports nothing of `checker`), imported
    on first use so that reading a CL file does not pay for numba."""
    from checker import kernels

    return kernels


def size_symbol_of(kind: str) -> str:
    """The name of the allowable variable of a cutter kind: 'r' for the ball family (ball,
    tapered ball), 'R' for flat, bull-nose and APT."""
    return "r" if kind in BALL_FAMILY else "R"


def _consistency_tol(d: float) -> float:
    """Slack (mm) for redundant values written with 4-6 decimals (NX writes 1e-4 inch)."""
    return 5e-3 + 1e-4 * max(d, 1.0)


def diameter_from(R: float, r: float, psi: float, theta: float) -> float:
    """APT diameter d where the bottom line meets the side line (thesis eq. 2.5), mm."""
    if psi == 0.0 and theta == 0.0:
        return 2.0 * (R + r)
    q = math.pi / 4.0 - theta / 2.0
    return 2.0 * R + 2.0 * r * math.sin(q + psi / 2.0) / math.cos(q - psi / 2.0)


def _canonical_angle(a: float) -> float:
    return math.radians(round(math.degrees(a), _ANGLE_DIGITS))


class SizeReach(NamedTuple):
    """Where the cutters of a family touching CC rows lie, as a function of the size s (tool
    frame, axis +z, mm; docs/MATH.md §5.1): the tip is horizontally at `c0 + s w` (N, 2) and at
    height `z0 - t s` (N,); the profile radius is at most `a s + side + flare max(0, z -
    base)` (a (N,), side and flare scalars, base (N,) heights). `sphere`: below the
    sphere/taper boundary (height of the sphere centre minus s sin_theta) the cutter is the
    sphere of centre cc + s n and radius s (ball family)."""

    c0: np.ndarray
    w: np.ndarray
    a: np.ndarray
    z0: np.ndarray
    t: np.ndarray
    base: np.ndarray
    side: float
    flare: float
    sphere: bool
    sin_theta: float


class CurvatureLimitForm(NamedTuple):
    """The closed-form size at the CC point (docs/MATH.md §3.7): `size (K,)` mm (inf: none
    from the form), `direction (K, 3)` the tangent along which the size tends to it (sign
    free), `form (K,)` where the closed form applies."""

    size: np.ndarray
    direction: np.ndarray
    form: np.ndarray


@dataclass(frozen=True)
class Cutter:
    """One cutter. `d` APT diameter, `r` corner radius, `R` axis -> corner centre, `H` length
    (0: unknown), holder/shank values None when unknown; mm. `psi` bottom cone angle and
    `theta` taper angle in radians."""

    kind: str
    d: float
    r: float
    R: float
    psi: float = 0.0
    theta: float = 0.0
    H: float = 0.0
    flute_length: float | None = None
    shank_diameter: float | None = None
    holder_diameter: float | None = None
    holder_length: float | None = None
    stickout: float | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise PathcheckError(
                f"cutter kind must be one of {', '.join(KINDS)}, found {self.kind!r}",
                code="cutter",
            )
        object.__setattr__(self, "psi", _canonical_angle(float(self.psi)))
        object.__setattr__(self, "theta", _canonical_angle(float(self.theta)))

    @property
    def size(self) -> float:
        """The allowable variable: R for flat, bull-nose and APT; r for ball and tapered ball."""
        return self.r if self.kind in BALL_FAMILY else self.R

    @property
    def ball_family(self) -> bool:
        """Ball and tapered ball: the allowable variable is the ball radius r."""
        return self.kind in BALL_FAMILY

    @property
    def size_symbol(self) -> str:
        """The allowable variable's name (`size_symbol_of`)."""
        return size_symbol_of(self.kind)

    @property
    def flat_bottomed(self) -> bool:
        """Whether the cutter has a flat bottom (a bottom plane below which it cuts nothing)."""
        return not self.ball_family and self.psi == 0.0

    @property
    def flat_end(self) -> bool:
        """A flat end-mill: flat bottom, sharp corner."""
        return self.flat_bottomed and self.r == 0.0

    @property
    def family_corner(self) -> float | None:
        """The corner radius that names the cutter's family in a tool library; None for the
        ball family (there r is the size)."""
        return None if self.ball_family else self.r

    @property
    def core(self) -> Core:
        """The cutter's solid as a core grown by a ball of radius r (`checker.cutter_core`)."""
        return Core(float(self.r), float(self.R), float(self.psi), float(self.theta))

    def cores(self, sizes: np.ndarray) -> Core:
        """The cores of the cutters of this family with the allowable sizes `sizes (N,)` (mm):
        one `Core` whose r and R are (N,) arrays."""
        r, R = self.radii(sizes)
        return Core(r, R, float(self.psi), float(self.theta))

    def radii(self, sizes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, R) (N,) of the cutters of this family with the allowable sizes `sizes` (mm)."""
        s = np.asarray(sizes, dtype=float)
        if self.ball_family:
            return s.copy(), np.zeros_like(s)
        return np.full_like(s, float(self.r)), s.copy()

    @property
    def family(self) -> int:
        """Kernel family code: `kernels.FAMILY_BALL` (r variable) or `FAMILY_APT` (R)."""
        return _kernels().FAMILY_BALL if self.kind in BALL_FAMILY else _kernels().FAMILY_APT

    def with_size(self, s: float) -> Cutter:
        """Same family (r, psi, theta or, for balls, theta), new size `s` (mm); d recomputed."""
        s = float(s)
        if self.kind in BALL_FAMILY:
            d = diameter_from(0.0, s, self.psi, self.theta)
            return replace(self, r=s, R=0.0, d=d)
        return replace(self, R=s, d=diameter_from(s, self.r, self.psi, self.theta))

    @property
    def f(self) -> float:
        """Height of the corner centre above the tip, mm (APT `f`)."""
        return self.R * math.tan(self.psi) + self.r / math.cos(self.psi)

    def to_apt(self) -> str:
        """`CUTTER/d,r,e,f,alpha,beta,h` (degrees) that parses back to an equal cutter."""
        vals = (
            self.d, self.r, self.R, self.f,
            math.degrees(self.psi), math.degrees(self.theta), self.H,
        )
        return "CUTTER/" + ",".join(repr(float(v)) for v in vals)

    # ---- closed forms ---------------------------------------------------------------------
    def kernel_params(self, tol: float = 0.0) -> np.ndarray:
        """Constants for `checker.kernels` (depth tolerance `tol`, mm); read-only, cached."""
        return _params(self.r, self.psi, self.theta, float(tol))

    def imaginary_size(
        self,
        p: np.ndarray,
        cc: np.ndarray,
        n: np.ndarray,
        e: np.ndarray | None = None,
        *,
        tol: float = 0.0,
    ) -> np.ndarray:
        """(K,) size (allowable variable, mm) of the imaginary cutter of this family that touches
        cc[i] with unit normal n[i] and passes through p[i]; (K,3) tool-frame arrays. `e` (K,3)
        is used only where n is vertical (else the worst case over directions). 0 / inf by the
        rules of `checker.kernels`, never NaN."""
        p, cc, n = (_as_k3(a, name) for a, name in ((p, "p"), (cc, "cc"), (n, "n")))
        if not (len(p) == len(cc) == len(n)):
            raise ValueError("p, cc and n must have the same length")
        ee, has_e = _e_arg(e, len(p))
        return _kernels().pair_sizes(p, cc, n, ee, has_e, self.family, self.kernel_params(tol))

    def tip_from_contact(
        self, cc: np.ndarray, n: np.ndarray, axis: np.ndarray, e: np.ndarray | None = None,
        sizes: np.ndarray | None = None,
    ) -> np.ndarray:
        """(N,3) tool tip (part frame, mm) of this cutter (or, row by row, of the cutter of its
        family with allowable size `sizes[i]`) touching cc with unit normal n at tool axis
        `axis` (N,3 or 3). Fillet contact: tip = cc + r n + R e - (R tan psi + r sec psi) a;
        tip contact (psi > 0, n.a > cos psi): tip = cc; normal along the axis: e from `e`
        (N,3), else the axis passes through cc (tip = cc: cc at the centre of the flat
        bottom)."""
        cc, n = _as_k3(cc, "cc"), _as_k3(n, "n")
        a = np.broadcast_to(np.asarray(axis, dtype=float), cc.shape)
        a = a / np.linalg.norm(a, axis=1, keepdims=True)
        na = np.einsum("ij,ij->i", n, a)
        perp = n - na[:, None] * a
        nh = np.linalg.norm(perp, axis=1)
        vertical = nh <= _kernels().EPS_H
        ev = np.zeros_like(perp)
        ev[~vertical] = perp[~vertical] / nh[~vertical, None]
        if e is not None and vertical.any():
            eg = np.broadcast_to(np.asarray(e, dtype=float), cc.shape)
            eg = eg - np.einsum("ij,ij->i", eg, a)[:, None] * a
            en = np.linalg.norm(eg, axis=1)
            use = vertical & (en > _kernels().EPS_H)
            ev[use] = eg[use] / en[use, None]
        if sizes is None:
            r, R = np.full(len(cc), float(self.r)), np.full(len(cc), float(self.R))
        else:
            r, R = self.radii(np.broadcast_to(np.asarray(sizes, dtype=float), (len(cc),)))
        f = R * math.tan(self.psi) + r / math.cos(self.psi)
        tip = cc + r[:, None] * n + R[:, None] * ev - f[:, None] * a
        tipc = self.tip_contact(na)
        tip[tipc] = cc[tipc]
        return tip

    # ---- the family interface ---------------------------------------------------------------
    def contact_case(self, nz: np.ndarray) -> np.ndarray:
        """(N,) int8 contact case (`checker.kernels` UNTOUCHABLE, FILLET, TIP) of CC points whose
        unit normals have tool-frame z components `nz (N,)`: `kernels.contact_case`, the one
        rule with the one slack (docs/MATH.md §3)."""
        nz = np.ascontiguousarray(nz, dtype=np.float64).ravel()
        return _kernels().contact_cases(nz, self.kernel_params())

    def untouchable(self, nz: np.ndarray) -> np.ndarray:
        """(N,) whether no cutter of the family touches the CC point tangentially (n_z <= 0 or
        n_z below sin(theta)): every size is 0 there."""
        return self.contact_case(nz) == _kernels().UNTOUCHABLE

    def fillet_contact(self, nz: np.ndarray) -> np.ndarray:
        """(N,) whether the corner arc (r = 0: the bottom edge) touches the CC point."""
        return self.contact_case(nz) == _kernels().FILLET

    def tip_contact(self, nz: np.ndarray) -> np.ndarray:
        """(N,) whether the cone's vertex touches the CC point (psi > 0, n_z > cos(psi))."""
        return self.contact_case(nz) == _kernels().TIP

    def size_reach(self, cc: np.ndarray, n: np.ndarray, e: np.ndarray,
                   degenerate: np.ndarray) -> SizeReach:
        """The `SizeReach` of the family's cutters touching `cc` with unit normal `n` (N, 3),
        axis towards unit horizontal `e` (N, 3), tool frame; `degenerate (N,)` rows without a
        direction e (the kernels' worst case over directions: |d| <= 2 s + k about the fillet
        centre). R family: fillet centre O = cc + r n, tip O - (r sec(psi) + s tan(psi)) z +
        s e; tip contact: tip at cc for every size. Ball family: tip cc + s (n - z)."""
        r, th = float(self.r), float(self.theta)
        tpos = max(np.tan(th), 0.0)
        if self.ball_family:
            z0 = cc[:, 2].copy()
            return SizeReach(cc[:, :2].copy(), n[:, :2].copy(), np.full(len(cc), 1.0 / np.cos(th)),
                             z0, 1.0 - n[:, 2], cc[:, 2], 0.0, tpos, True,
                             max(np.sin(th), 0.0))
        psi = float(self.psi)
        O = cc + r * n
        z0 = O[:, 2] - r / np.cos(psi)
        t = np.full(len(cc), np.tan(psi))
        c0, w, a = O[:, :2], e[:, :2].copy(), np.ones(len(cc))
        w[degenerate], a[degenerate] = 0.0, 2.0
        tip = self.tip_contact(n[:, 2])  # cone tip on cc, axis through cc
        c0[tip], w[tip], z0[tip], t[tip] = cc[tip, :2], 0.0, cc[tip, 2], 0.0
        return SizeReach(c0, w, a, z0, t, np.minimum(O[:, 2], cc[:, 2]), r / np.cos(th), tpos,
                         False, 0.0)

    def curvature_limit(self, n: np.ndarray, e: np.ndarray,
                        basis: Callable[[], tuple[np.ndarray, np.ndarray]],
                        forms: Callable[[np.ndarray, np.ndarray], tuple]) -> CurvatureLimitForm:
        """The size in the limit P -> Pcc (docs/MATH.md §3.7) at CC rows with unit normals `n`
        and unit horizontal `e` (K, 3), tool frame. `basis()` gives an orthonormal tangent basis
        (t1, t2) (K, 3) and `forms(t1, t2)` the surface's second fundamental form (a, b, c) =
        II(t1, t1), II(t1, t2), II(t2, t2) (K,) in any tangent basis (positive towards the tool).
        Ball family: 1 / k_max along the direction of k_max. R family: the corner torus's limit
        R_lim = h / k - r h (k = c + b^2 r / (1 - a r) in the basis (t_m, t_c)), where the
        contact case is the fillet and e is defined."""
        if self.ball_family:
            t1, t2 = basis()
            a, b, c = forms(t1, t2)
            half = np.sqrt((0.5 * (a - c)) ** 2 + b * b)
            k_max = 0.5 * (a + c) + half
            with np.errstate(divide="ignore"):
                lim = np.where(k_max > 0.0, 1.0 / k_max, np.inf)
            angle = 0.5 * np.arctan2(2.0 * b, a - c)  # the direction of k_max from t1
            t = np.cos(angle)[:, None] * t1 + np.sin(angle)[:, None] * t2
            return CurvatureLimitForm(lim, t, np.ones(len(n), dtype=bool))
        r = float(self.r)
        h = np.hypot(n[:, 0], n[:, 1])
        tc = np.column_stack([-e[:, 1], e[:, 0], np.zeros(len(e))])  # z x e
        tm = np.cross(tc, n)
        a, b, c = forms(tm, tc)
        den = 1.0 - a * r
        with np.errstate(divide="ignore", invalid="ignore"):
            k = c + b * b * r / den
            lim = np.where(den <= 0.0, 0.0, np.where(k > 0.0, h / k - r * h, np.inf))
        defined = (h > _kernels().EPS_H) & (np.linalg.norm(e, axis=1) > 0.5)
        direction = (b * r)[:, None] * tm + np.where(den > 0.0, den, 0.0)[:, None] * tc
        direction = np.where((den > 0.0)[:, None], direction, tm)
        form = self.fillet_contact(n[:, 2]) & defined
        return CurvatureLimitForm(np.where(form, lim, np.inf), direction, form)

    def _profile_pieces(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(dz, on_taper, on_fillet): the height above the corner centre of heights z (mm above
        the tip) and which piece of the profile holds them (the cone or flat bottom
        elsewhere; docs/MATH.md §2)."""
        dz = z - self.f
        taper = dz >= -self.r * math.sin(self.theta)
        return dz, taper, ~taper & (dz > -self.r * math.cos(self.psi))

    def profile_radius(self, z: np.ndarray) -> np.ndarray:
        """(N,) radius of the cutter's solid of revolution at height z (mm) above the tip
        (OpenCAMLib's width(h)); 0 below the tip and above H (H > 0)."""
        z = np.asarray(z, dtype=float)
        R = 0.0 if self.kind in BALL_FAMILY else self.R
        r, psi, theta = self.r, self.psi, self.theta
        dz, on_taper, on_fillet = self._profile_pieces(z)
        with np.errstate(invalid="ignore"):
            taper = R + dz * math.tan(theta) + r / math.cos(theta)
            fillet = R + np.sqrt(np.maximum(r * r - dz * dz, 0.0))
            cone = z / math.tan(psi) if psi > 0.0 else np.where(z >= 0.0, R, 0.0)
        out = np.where(on_taper, taper, np.where(on_fillet, fillet, cone))
        out = np.where(z < 0.0, 0.0, out)
        if self.H > 0.0:
            out = np.where(z > self.H, 0.0, out)
        return out

    def profile_slope(self, z: np.ndarray) -> np.ndarray:
        """(N,) d(profile radius)/dz at heights z (mm above the tip): tan(theta) on the side,
        -dz / sqrt(r^2 - dz^2) on the corner arc, cot(psi) on the cone, inf at a flat bottom."""
        z = np.asarray(z, dtype=float)
        r = self.r
        dz, on_taper, on_fillet = self._profile_pieces(z)
        with np.errstate(divide="ignore", invalid="ignore"):
            fillet = -dz / np.sqrt(np.maximum(r * r - dz * dz, 0.0))
        cone = 1.0 / math.tan(self.psi) if self.psi > 0.0 else np.inf
        return np.where(on_taper, math.tan(self.theta), np.where(on_fillet, fillet, cone))

    def signed_distance(self, pts: np.ndarray) -> np.ndarray:
        """(N,) signed distance (mm) from tool-frame points (tip at origin, axis +z) to the
        cutter solid (flutes up to H; unbounded above when H = 0): negative inside. The solid
        is the core grown by r (`checker.cutter_core`), cut at H by a plane."""
        pts = _as_k3(pts, "pts")
        n = len(pts)
        d = core_signed_distance(self.core, pts, np.zeros((n, 3)), np.tile([0.0, 0.0, 1.0], (n, 1)))
        if self.H <= 0.0:
            return d
        above = pts[:, 2] - self.H  # > 0 above the top plane
        rho = np.hypot(pts[:, 0], pts[:, 1])
        rim = self.profile_radius(np.full(n, self.H))
        over = (above > 0.0) & (rho > rim)  # beyond the top's rim: distance to the rim circle
        out = np.maximum(d, above)
        out[over] = np.hypot(above[over], rho[over] - rim[over])
        return out


@lru_cache(maxsize=256)
def _params(r: float, psi: float, theta: float, tol: float) -> np.ndarray:
    out = _kernels().params(r, psi, theta, tol)
    out.flags.writeable = False
    return out


def _as_k3(a: np.ndarray, name: str) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (K, 3), got {a.shape}")
    return a


def _e_arg(e: np.ndarray | None, k: int) -> tuple[np.ndarray, bool]:
    if e is None:
        return np.zeros((1, 3)), False
    e = _as_k3(e, "e")
    if len(e) != k:
        raise ValueError("e must have the same length as cc")
    return e, True


# ---- parsing and validation -------------------------------------------------------------------


def _fail(msg: str, path: str | Path | None, line: int | None) -> PathcheckError:
    return PathcheckError(msg, path=path, line=line, code="cutter")


def _check_values(values, names, path, line, stmt: str) -> list[float]:
    out = []
    for v, nm in zip(values, names, strict=True):
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise _fail(f"{stmt}: {nm} must be a number, found {v!r}", path, line) from None
        if not math.isfinite(x):
            raise _fail(f"{stmt}: {nm} must be a finite number, found {v!r}", path, line)
        if x < 0.0:
            raise _fail(f"{stmt}: {nm} must be >= 0, found {x:g}", path, line)
        out.append(x)
    return out


def _kind_of(r: float, R: float, psi: float, theta: float) -> str:
    if psi == 0.0 and theta == 0.0:
        return "flat" if r == 0.0 else ("ball" if R == 0.0 else "bullnose")
    return "tapered_ball" if (psi == 0.0 and R == 0.0 and r > 0.0) else "apt"


def _check_angles(psi_deg, theta_deg, path, line, stmt) -> None:
    if psi_deg + theta_deg >= 90.0:
        raise _fail(
            f"{stmt}: bottom angle {psi_deg:g} and taper angle {theta_deg:g} degrees must each be "
            "below 90 and sum below 90",
            path,
            line,
        )


def _make(d, r, R, psi_deg, theta_deg, H, path, line, stmt) -> Cutter:
    _check_angles(psi_deg, theta_deg, path, line, stmt)
    if abs(R) <= 1e-9 * d:
        R = 0.0  # a corner radius of half the diameter (rounding in the file): a ball
    if d <= 0.0:
        raise _fail(f"{stmt}: diameter must be > 0, found {d:g}", path, line)
    psi, theta = math.radians(psi_deg), math.radians(theta_deg)
    return Cutter(_kind_of(r, R, psi, theta), d, r, R, psi, theta, H)


def _check_redundant(d, r, e, f, a_deg, b_deg, path, line, stmt, names) -> None:
    """d and f repeat what r, e, alpha, beta say (eq. 2.5; f = e tan(alpha) + r sec(alpha)):
    name the value that disagrees."""
    nd, nr, ne, nf = names
    psi, th = math.radians(a_deg), math.radians(b_deg)
    tol = _consistency_tol(d)
    d_exp = diameter_from(e, r, psi, th)
    f_exp = e * math.tan(psi) + r / math.cos(psi)
    d_ok, f_ok = abs(d - d_exp) <= tol, abs(f - f_exp) <= tol
    if d_ok and f_ok:
        return
    if not d_ok and f_ok:
        raise _fail(
            f"{stmt}: {nd}={d:g} is inconsistent with {nr}={r:g}, {ne}={e:g}, angles {a_deg:g}/"
            f"{b_deg:g} deg: eq. 2.5 gives {nd}={d_exp:.6g}",
            path,
            line,
        )
    if d_ok and not f_ok:
        raise _fail(
            f"{stmt}: {nf}={f:g} is inconsistent with {ne}={e:g}, {nr}={r:g}, bottom angle "
            f"{a_deg:g} deg: expected {nf}={f_exp:.6g} (height of the corner centre)",
            path,
            line,
        )
    e_from_d = 0.5 * (d - (diameter_from(0.0, r, psi, th)))
    raise _fail(
        f"{stmt}: {ne}={e:g} is inconsistent with both {nd}={d:g} (which implies {ne}="
        f"{e_from_d:.6g}) and {nf}={f:g} (expected {nf}={f_exp:.6g} for this {ne})",
        path,
        line,
    )


def cutter_from_apt(
    values: list[float], *, path: str | Path | None = None, line: int | None = None
) -> Cutter:
    """Cutter from the values of an APT `CUTTER/` statement (mm, angles in degrees):
    1 value (d: flat), 2 (d, r: bull-nose, ball when r = d/2, flat when r = 0) or 7
    (d, r, e, f, alpha, beta, h: e = R, alpha = psi, beta = theta, h = H)."""
    stmt = "CUTTER"
    n = len(values)
    if n == 1:
        (d,) = _check_values(values, ("d",), path, line, stmt)
        return _make(d, 0.0, d / 2.0, 0.0, 0.0, 0.0, path, line, stmt)
    if n == 2:
        d, r = _check_values(values, ("d", "r"), path, line, stmt)
        if r > d / 2.0 * (1 + 1e-12):
            raise _fail(
                f"{stmt}: corner radius r={r:g} is larger than half the diameter d={d:g}",
                path,
                line,
            )
        R = 0.0 if r >= d / 2.0 else d / 2.0 - r
        return _make(d, r, R, 0.0, 0.0, 0.0, path, line, stmt)
    if n == 7:
        names = ("d", "r", "e", "f", "alpha", "beta", "h")
        d, r, e, f, a, b, h = _check_values(values, names, path, line, stmt)
        _check_angles(a, b, path, line, stmt)
        _check_redundant(d, r, e, f, a, b, path, line, stmt, ("d", "r", "e", "f"))
        return _make(d, r, e, a, b, h, path, line, stmt)
    raise _fail(
        f"{stmt}: expected 1, 2 or 7 values (d | d,r | d,r,e,f,alpha,beta,h), found {n}",
        path,
        line,
    )


def cutter_from_tldata(
    values: list[float], *, path: str | Path | None = None, line: int | None = None
) -> Cutter:
    """Cutter from the numbers after `TLDATA/MILL,` (mm, degrees): 5 (D, R1, L, B taper, A tip),
    7 (+ XC, YC: corner centre radial and axial distance) or 10 (+ R2, X2, Y2: upper corner,
    validated and ignored)."""
    stmt = "TLDATA/MILL"
    n = len(values)
    if n not in (5, 7, 10):
        raise _fail(
            f"{stmt}: expected 5, 7 or 10 values (D,R1,L,B,A[,XC,YC[,R2,X2,Y2]]), found {n}",
            path,
            line,
        )
    names = ("diameter", "lower radius", "length", "taper angle", "tip angle",
             "corner centre x", "corner centre y", "upper radius", "upper centre x",
             "upper centre y")[:n]
    v = _check_values(values, names, path, line, stmt)
    d, r, L, taper, tip = v[:5]
    _check_angles(tip, taper, path, line, stmt)
    if n == 5:
        R = 0.5 * (d - diameter_from(0.0, r, math.radians(tip), math.radians(taper)))
        if R + _consistency_tol(d) < 0.0:
            raise _fail(
                f"{stmt}: lower radius {r:g} is larger than half the diameter {d:g} allows "
                f"(taper {taper:g}, tip {tip:g} deg)",
                path,
                line,
            )
        R = max(R, 0.0)
    else:
        R, f = v[5], v[6]
        _check_redundant(
            d, r, R, f, tip, taper, path, line, stmt,
            ("diameter", "lower radius", "corner centre x", "corner centre y"),
        )
    return _make(d, r, R, tip, taper, L, path, line, stmt)


def parse_cutter_in(text: str, units: str) -> Cutter:
    """`parse_cutter` of a statement whose lengths are in `units` ("mm" or "inch"), as a CL
    file of those units states it: angles stay degrees, lengths come back in mm."""
    cutter = parse_cutter(text)
    if units != "inch":
        return cutter
    lengths = ("d", "r", "R", "H", "flute_length", "shank_diameter", "holder_diameter",
               "holder_length", "stickout")
    return replace(cutter, **{k: getattr(cutter, k) * MM_PER_INCH for k in lengths
                              if getattr(cutter, k) is not None})


def parse_cutter(
    text: str, *, path: str | Path | None = None, line: int | None = None
) -> Cutter:
    """Cutter from a whole statement: "CUTTER/10,2", "CUTTER/d,r,e,f,a,b,h" or
    "TLDATA/MILL,D,R1,L,B,A..." (values in mm)."""
    s = " ".join(str(text).split())
    word, sep, rest = s.partition("/")
    word = word.strip().upper()
    if not sep or word not in ("CUTTER", "TLDATA"):
        raise _fail(
            f"expected a cutter statement 'CUTTER/d[,r[,e,f,alpha,beta,h]]' or "
            f"'TLDATA/MILL,...', found {s[:60]!r}",
            path,
            line,
        )
    parts = [t.strip() for t in rest.split(",")]
    if word == "TLDATA":
        if not parts or parts[0].upper() != "MILL":
            found = parts[0] if parts else ""
            raise _fail(
                f"TLDATA: only TLDATA/MILL is a milling cutter, found TLDATA/{found}", path, line
            )
        return cutter_from_tldata(parts[1:], path=path, line=line)
    if parts == [""]:
        parts = []
    return cutter_from_apt(parts, path=path, line=line)
