"""Build every sample job: parts as geomdl exchange JSON, tool paths as APT-CL (ISO 4343 style).

Deterministic (no random numbers, fixed formatting). Run from the repository root:
`.venv/bin/python -m samples.make_samples` (or `python samples/make_samples.py`).
samples/README.md says how each sample is built. Geometry in mm; the compressor's rotary axis is
the part's Y axis through the origin; the mould's tool axis is +Z.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from geomdl import NURBS, exchange, multi

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from checker.cutter import Cutter, cutter_from_apt  # noqa: E402
from checker.cutter_core import Core, signed_distance  # noqa: E402
from checker.geometry import load_part  # noqa: E402
from checker.geometry.evaluate import evaluate  # noqa: E402
from checker.part import Part  # noqa: E402
from checker.resources import resource  # noqa: E402

HERE = Path(__file__).resolve().parent

# ---- compressor segment (thesis chapter 5: 4-axis about Y) ----------------------------------
N_BLADES = 24                  # blades of the full stage; the segment holds three of them
PITCH = 2 * np.pi / N_BLADES   # rad
R_HUB = 80.0                   # mm, hub radius
R_ROOT = 78.0                  # mm, blade poles start 2 mm inside the hub (no gap at the root)
R_TIP = 116.0                  # mm, blade tip radius (36 mm above the hub)
HUB_Y = 32.0                   # mm, hub spans y in [-HUB_Y, HUB_Y]
BLADE_PHI = (-PITCH, 0.0, PITCH)
COMP_CUTTER = (6.0, 3.0)       # CUTTER/6,3: ball end-mill D6
COMP_TILT = np.radians(20.0)   # CAM rule: axis tilted from radial towards the surface normal
COMP_GRID = 41                 # thesis chapter 5: 41 x 41 CC points per surface
COMP_V0 = 0.18                 # lowest CC row: about 4.8 mm above the hub
CLEAR_RADIUS = 160.0           # mm, rapid moves between passes stay outside this radius

# ---- mould cavity (thesis chapter 4: hair-dryer mould, 3-axis) ------------------------------
CAV_X, CAV_Y = 60.0, 35.0      # cavity opening [-CAV_X, CAV_X] x [-CAV_Y, CAV_Y] at z = 0
PLATE_X, PLATE_Y = 80.0, 55.0  # parting plane around it
MOULD_CUTTER = (10.0, 5.0)     # CUTTER/10,5: ball end-mill D10
MOULD_ROW_STEP = 3.0           # mm between zig-zag rows (along y)
MOULD_STEP = 2.0               # mm between CC points along a row (along x)
SAFE_Z = 25.0                  # mm, rapid plane of the mould job


@dataclass
class Pass:
    """One cutting pass: CC points, normals and tool axes (K,3), the tips computed from them."""

    cc: np.ndarray
    normals: np.ndarray
    axes: np.ndarray
    tips: np.ndarray


def _surface(name: str, degree_u: int, degree_v: int, knots_u, knots_v, poles: np.ndarray,
             weights: np.ndarray | None = None) -> NURBS.Surface:
    """A geomdl NURBS surface from poles (nu, nv, 3) in mm and optional weights (nu, nv)."""
    nu, nv = poles.shape[:2]
    w = np.ones((nu, nv)) if weights is None else weights
    s = NURBS.Surface()
    s.degree_u, s.degree_v = degree_u, degree_v
    s.ctrlpts_size_u, s.ctrlpts_size_v = nu, nv
    s.ctrlpts = [[float(c) for c in p] for p in poles.reshape(-1, 3)]
    s.weights = [float(x) for x in w.ravel()]
    s.knotvector_u, s.knotvector_v = list(knots_u), list(knots_v)
    s.name = name
    return s


def _clamped(degree: int, interior=()) -> list[float]:
    return [0.0] * (degree + 1) + [float(k) for k in interior] + [1.0] * (degree + 1)


def _greville(knots: list[float], degree: int) -> np.ndarray:
    k = np.asarray(knots)
    n = len(k) - degree - 1
    return np.array([k[i + 1:i + 1 + degree].mean() for i in range(n)])


# ---- compressor geometry ----------------------------------------------------------------------
def hub_surface() -> NURBS.Surface:
    """Exact rational hub: the cylinder of radius R_HUB about Y over the segment's angle (one
    rational quadratic arc in u, angle increasing; a line in v along +Y), normal outwards."""
    half = 1.5 * PITCH
    ang = np.array([-half, 0.0, half])
    rad = np.array([R_HUB, R_HUB / np.cos(half), R_HUB])
    ys = np.array([-HUB_Y, HUB_Y])
    poles = np.empty((3, 2, 3))
    for i in range(3):
        for j in range(2):
            poles[i, j] = (rad[i] * np.sin(ang[i]), ys[j], rad[i] * np.cos(ang[i]))
    weights = np.array([[1.0, 1.0], [np.cos(half)] * 2, [1.0, 1.0]])
    return _surface("hub", 2, 1, _clamped(2), _clamped(1), poles, weights)


def blade_poles(phi0: float, side: int) -> np.ndarray:
    """6 x 6 poles of one blade side (side +1 suction, -1 pressure) of the blade at angle phi0.

    Sections at six radii from R_ROOT to R_TIP: chord 48-54 mm, stagger 35-50 deg from the axial
    direction (twist), parabolic camber 6-4 % and thickness 8-5 % of the chord, laid on the
    cylinder of that radius (axial coordinate m -> y, arc length s -> angle s / radius). Both
    sides share their first and last pole columns: the leading and trailing edges are sharp C0
    edges. Chord index i runs leading -> trailing edge on the suction side and trailing ->
    leading on the pressure side, so du x dv points out of the blade on both.
    """
    x = np.linspace(0.0, 1.0, 6)[:, None]
    t = np.linspace(0.0, 1.0, 6)[None, :]
    rho = R_ROOT + (R_TIP - R_ROOT) * t
    chord = 48.0 + 6.0 * t
    gamma = np.radians(35.0 + 15.0 * t)
    camber = 4.0 * (0.06 - 0.02 * t) * chord * x * (1.0 - x)
    half_thick = 0.5 * (0.08 - 0.03 * t) * chord * np.array([0, 0.9, 1.0, 0.8, 0.45, 0])[:, None]
    off = camber + side * half_thick
    m = (x - 0.5) * chord * np.cos(gamma) - off * np.sin(gamma)
    s = (x - 0.5) * chord * np.sin(gamma) + off * np.cos(gamma)
    phi = phi0 + s / rho
    poles = np.stack([rho * np.sin(phi), m * np.ones_like(rho), rho * np.cos(phi)], axis=-1)
    return poles if side > 0 else poles[::-1]


def compressor_surfaces() -> list[NURBS.Surface]:
    """Hub + three blades, each with a pressure and a suction side (degree 5, 6 x 6 poles)."""
    out = [hub_surface()]
    for k, phi in enumerate(BLADE_PHI):
        for side, label in ((-1, "pressure"), (1, "suction")):
            out.append(_surface(f"blade{k - 1:+d}_{label}", 5, 5, _clamped(5), _clamped(5),
                                blade_poles(phi, side)))
    return out


# ---- mould geometry -------------------------------------------------------------------------
def _cavity_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Design height (mm) of the cavity floor: a bowl about 28 mm deep, lopsided in y, a ridge
    across it at x = 0 (the crease between body and nozzle, made C0 by the poles at the patch
    edge) and a boss 9 mm high; zero on the rim."""
    X, Y = x / CAV_X, y / CAV_Y
    bowl = -28.0 * (1.0 - X**2)
    ridge = 7.0 * (np.exp(-np.abs(X) / 0.35) - np.exp(-1.0 / 0.35))
    boss = 9.0 * np.exp(-((x - 30.0) ** 2 + (y + 10.0) ** 2) / (2 * 9.0**2)) * (1.0 - X**2)
    across = (1.0 - Y**2) * (1.0 + 0.4 * Y)     # deeper and steeper towards +y
    return (bowl + ridge + boss) * across


def mould_surfaces() -> list[NURBS.Surface]:
    """Four bicubic cavity patches and four flat parting-plane patches (u along +x, v along +y,
    normals +z side up). Each cavity patch has 6 x 5 poles at the Greville abscissae of its knot
    vectors (so x and y are linear in u and v) with heights from `_cavity_height`; neighbours
    share their boundary poles. Across x = 0 the pole columns beside the edge slope opposite
    ways: a C0 crease (the ridge). Across y = 0 the pole rows beside the join mirror each other
    about it: C1. The cavity meets the parting plane at the rim in a convex C0 edge."""
    p = 3
    knots_half_u = _clamped(p, (1 / 3, 2 / 3))     # each half in x: simple interior knots (C2)
    knots_half_v = _clamped(p, (0.5,))
    out = []
    for iy, (y0, y1) in enumerate(((-CAV_Y, 0.0), (0.0, CAV_Y))):
        for ix, (x0, x1) in enumerate(((-CAV_X, 0.0), (0.0, CAV_X))):
            gu = x0 + (x1 - x0) * _greville(knots_half_u, p)
            gv = y0 + (y1 - y0) * _greville(knots_half_v, p)
            X, Y = np.meshgrid(gu, gv, indexing="ij")
            poles = np.stack([X, Y, _cavity_height(X, Y)], axis=-1)
            out.append(_surface(f"cavity_{'LR'[ix]}{'FB'[iy]}", p, p, knots_half_u, knots_half_v,
                                poles))
    _make_c1_in_v(out)
    plates = (("plate_front", -PLATE_X, PLATE_X, -PLATE_Y, -CAV_Y),
              ("plate_back", -PLATE_X, PLATE_X, CAV_Y, PLATE_Y),
              ("plate_left", -PLATE_X, -CAV_X, -CAV_Y, CAV_Y),
              ("plate_right", CAV_X, PLATE_X, -CAV_Y, CAV_Y))
    for name, x0, x1, y0, y1 in plates:
        X, Y = np.meshgrid([x0, x1], [y0, y1], indexing="ij")
        out.append(_surface(name, 1, 1, _clamped(1), _clamped(1),
                            np.stack([X, Y, np.zeros_like(X)], axis=-1)))
    return out


def _make_c1_in_v(patches: list[NURBS.Surface]) -> None:
    """Make the join at y = 0 between front and back cavity patches C1: the shared boundary row
    is the mean of both, and the rows beside it mirror each other about it (equal spans)."""
    for front, back in ((patches[0], patches[2]), (patches[1], patches[3])):
        nu, nv = front.ctrlpts_size_u, front.ctrlpts_size_v
        f = np.asarray(front.ctrlpts).reshape(nu, nv, 3)
        b = np.asarray(back.ctrlpts).reshape(nu, nv, 3)
        slope = 0.5 * (b[:, 1, 2] - f[:, -2, 2])
        mid = 0.5 * (f[:, -1, 2] + b[:, 0, 2])
        f[:, -1, 2] = b[:, 0, 2] = mid
        f[:, -2, 2], b[:, 1, 2] = mid - slope, mid + slope
        for s, poles in ((front, f), (back, b)):
            s.ctrlpts = [[float(c) for c in q] for q in poles.reshape(-1, 3)]
            s.weights = [1.0] * (nu * nv)


# ---- files ------------------------------------------------------------------------------------
def write_part(surfaces: list[NURBS.Surface], path: Path) -> Part:
    """geomdl exchange JSON of all surfaces (with their names), read back with `load_part`."""
    exchange.export_json(multi.SurfaceContainer(surfaces), str(path))
    doc = json.loads(path.read_text())
    for entry, s in zip(doc["shape"]["data"], surfaces, strict=True):
        entry["name"] = s.name
        entry.pop("delta", None)
    path.write_text(json.dumps(doc, indent=1) + "\n")
    return load_part(path)


def _fmt(v: np.ndarray, digits: int) -> str:
    return ",".join(f"{x:.{digits}f}".replace("-0." + "0" * digits, "0." + "0" * digits)
                    for x in v)


def write_apt(path: Path, header: list[str], blocks: list[tuple[str, np.ndarray, np.ndarray]],
              multax: bool) -> int:
    """APT-CL file: header statements, then per block ('rapid' | 'feed' | 'plunge') its tips
    (K,3) and axes (K,3), written as GOTO/x,y,z[,i,j,k]; returns the number of GOTOs."""
    lines = list(header)
    mode = None
    count = 0
    for kind, tips, axes in blocks:
        if kind != "rapid" and kind != mode:
            lines.append("FEDRAT/800.0,MMPM" if kind == "feed" else "FEDRAT/250.0,MMPM")
        mode = kind if kind != "rapid" else mode
        for tip, ax in zip(tips, axes, strict=True):
            if kind == "rapid":
                lines.append("RAPID")
            coords = _fmt(tip, 4) + ("," + _fmt(ax, 7) if multax else "")
            lines.append(f"GOTO/{coords}")
            count += 1
    lines += ["END", "FINI"]
    path.write_text("\n".join(lines) + "\n")
    return count


# ---- compressor path --------------------------------------------------------------------------
def write_cc_csv(path: Path, passes: list[Pass], count: int) -> None:
    """About `count` CC points of the passes, evenly spread, with their surface normals: the
    `pathcheck allowable --cc` input (header x,y,z,nx,ny,nz; part frame, mm)."""
    cc = np.concatenate([p.cc for p in passes])
    nn = np.concatenate([p.normals for p in passes])
    pick = np.linspace(0, len(cc) - 1, min(count, len(cc))).round().astype(int)
    table = np.round(np.hstack([cc[pick], nn[pick]]), 6) + 0.0  # no "-0.000000"
    rows = [",".join(f"{x:.6f}" for x in row) for row in table]
    path.write_text("x,y,z,nx,ny,nz\n" + "\n".join(rows) + "\n")


def compressor_axes(cc: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """The CAM's tool axes (K,3) with j = 0: the radial direction at the CC point (in the XZ
    plane) turned by COMP_TILT towards the side the surface faces (the XZ part of its normal)."""
    phi = np.arctan2(cc[:, 0], cc[:, 2])
    radial = np.stack([np.sin(phi), np.zeros_like(phi), np.cos(phi)], axis=1)
    circ = np.stack([np.cos(phi), np.zeros_like(phi), -np.sin(phi)], axis=1)
    side = np.sign(np.einsum("ij,ij->i", normals, circ))[:, None]
    axes = np.cos(COMP_TILT) * radial + np.sin(COMP_TILT) * side * circ
    axes[:, 1] = 0.0
    return axes


def grid_pass(part: Part, sid: int, us: np.ndarray, vs: np.ndarray, cutter: Cutter,
              axes_rule) -> Pass:
    """Zig-zag over a (u, v) grid of one surface: rows of constant v, u reversed every other row."""
    U, V = np.meshgrid(us, vs)                  # rows along u
    U[1::2] = U[1::2, ::-1]
    ev = evaluate(part.surfaces[sid], U.ravel(), V.ravel())
    axes = axes_rule(ev.points, ev.normals)
    return Pass(ev.points, ev.normals, axes, cutter.tip_from_contact(ev.points, ev.normals, axes))


def _surface_id(part: Part, name: str) -> int:
    return next(s.id for s in part.surfaces if s.name == name)


def _radial_out(tip: np.ndarray, axis: np.ndarray, radius: float) -> np.ndarray:
    """The point on the ray tip + t axis (t >= 0) at distance `radius` from the Y axis."""
    a2 = axis[0] ** 2 + axis[2] ** 2
    b = tip[0] * axis[0] + tip[2] * axis[2]
    c = tip[0] ** 2 + tip[2] ** 2 - radius**2
    t = (-b + np.sqrt(b * b - a2 * c)) / a2
    return tip + t * axis


def compressor_blocks(passes: list[Pass]) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Each pass: rapid to the clearance radius on its first axis, plunge along the axis to the
    first CL point, cut, retract along the last axis to the clearance radius."""
    blocks = []
    for ps in passes:
        a0, a1 = ps.axes[0], ps.axes[-1]
        start = _radial_out(ps.tips[0], a0, CLEAR_RADIUS)
        blocks.append(("rapid", start[None], a0[None]))
        blocks.append(("plunge", (ps.tips[0] + 5.0 * a0)[None], a0[None]))
        blocks.append(("feed", ps.tips, ps.axes))
        blocks.append(("rapid", _radial_out(ps.tips[-1], a1, CLEAR_RADIUS)[None], a1[None]))
    return blocks


def compressor_header(title: str, cutter: tuple[float, float]) -> list[str]:
    return [f"PARTNO/{title}", "PPRINT/MACHINE fanuc-hmc", "UNITS/MM", "MULTAX",
            f"CUTTER/{cutter[0]:g},{cutter[1]:g}", "LOADTL/1", "SPINDL/12000,RPM,CLW"]


def blade_passes(part: Part, cutter: Cutter, n_u: int, n_v: int) -> list[Pass]:
    """Zig-zag passes over an n_u x n_v CC grid on blade 0's pressure side, then its suction
    side, for `cutter` with the CAM's axes."""
    us, vs = np.linspace(0.0, 1.0, n_u), np.linspace(COMP_V0, 1.0, n_v)
    return [grid_pass(part, _surface_id(part, f"blade+0_{side}"), us, vs, cutter, compressor_axes)
            for side in ("pressure", "suction")]


def build_compressor(folder: Path) -> dict:
    """compressor.json/.apt (2 x 41 x 41 CC points, ball D6); compressor_small.json/.apt (the
    same on 2 x 9 x 5 CC points) and compressor_small_d12.json/.apt (those CC points and axes
    with a ball D12: tips recomputed, the larger cutter to be flagged); cc.csv (the 90 CC
    points of compressor_small)."""
    folder.mkdir(parents=True, exist_ok=True)
    part = write_part(compressor_surfaces(), folder / "compressor.json")
    cutter = cutter_from_apt(list(COMP_CUTTER))
    passes = blade_passes(part, cutter, COMP_GRID, COMP_GRID)
    title = "COMPRESSOR BLADE 0 PRESSURE AND SUCTION 41X41"
    gotos = [write_apt(folder / "compressor.apt", compressor_header(title, COMP_CUTTER),
                       compressor_blocks(passes), multax=True)]
    for stem, size in (("compressor_small", COMP_CUTTER), ("compressor_small_d12", (12.0, 6.0))):
        write_part(compressor_surfaces(), folder / f"{stem}.json")
        title = f"COMPRESSOR BLADE 0 PRESSURE AND SUCTION 9X5 BALL D{size[0]:g}"
        gotos.append(write_apt(folder / f"{stem}.apt", compressor_header(title, size),
                               compressor_blocks(blade_passes(part, cutter_from_apt(list(size)),
                                                              9, 5)), multax=True))
    write_cc_csv(folder / "cc.csv", blade_passes(part, cutter, 9, 5), 90)
    return {"part": part, "passes": passes, "cutter": cutter, "goto": tuple(gotos)}


# ---- mould path -------------------------------------------------------------------------------
def mould_pass(part: Part, cutter: Cutter) -> Pass:
    """Zig-zag rows along x at constant y over the four cavity patches, vertical tool axis.
    At the C0 ridge (x = 0) the cutter rolls over the crease: extra CL points with the CC point
    fixed on the crease and the normal turned from one patch's normal to the other's."""
    xs_half = np.arange(0.0, CAV_X + 1e-9, MOULD_STEP)
    ys = np.arange(-CAV_Y + MOULD_ROW_STEP, CAV_Y - 1e-9, MOULD_ROW_STEP)
    cc_rows, n_rows = [], []
    for k, y in enumerate(ys):
        iy = 0 if y < 0 else 1
        v = (y + CAV_Y) / CAV_Y if iy == 0 else y / CAV_Y
        left = evaluate(part.surfaces[2 * iy], xs_half / CAV_X, np.full(xs_half.size, v))
        right = evaluate(part.surfaces[2 * iy + 1], xs_half / CAV_X, np.full(xs_half.size, v))
        turn = np.linspace(0.0, 1.0, 7)[1:-1, None]
        roll = left.normals[-1] * (1 - turn) + right.normals[0] * turn
        roll /= np.linalg.norm(roll, axis=1)[:, None]
        crease = np.repeat(left.points[-1:], len(turn), 0)
        cc = np.concatenate([left.points, crease, right.points[1:]])
        nn = np.concatenate([left.normals, roll, right.normals[1:]])
        if k % 2:
            cc, nn = cc[::-1], nn[::-1]
        cc_rows.append(cc)
        n_rows.append(nn)
    cc, nn = np.concatenate(cc_rows), np.concatenate(n_rows)
    axes = np.tile([0.0, 0.0, 1.0], (len(cc), 1))
    return Pass(cc, nn, axes, cutter.tip_from_contact(cc, nn, axes))


def build_mould(folder: Path) -> dict:
    """mould.json (8 patches), mould.apt (3-axis zig-zag, ball D10) and cc.csv (100 of its CC
    points)."""
    folder.mkdir(parents=True, exist_ok=True)
    part = write_part(mould_surfaces(), folder / "mould.json")
    cutter = cutter_from_apt(list(MOULD_CUTTER))
    ps = mould_pass(part, cutter)
    up = np.array([[0.0, 0.0, 1.0]])
    first, last = ps.tips[:1].copy(), ps.tips[-1:].copy()
    first[:, 2] = last[:, 2] = SAFE_Z
    blocks = [("rapid", first, up), ("plunge", ps.tips[:1] + [0, 0, 5.0], up),
              ("feed", ps.tips, ps.axes), ("rapid", last, up)]
    header = ["PARTNO/MOULD CAVITY ZIGZAG BALL D10", "UNITS/MM",
              f"CUTTER/{MOULD_CUTTER[0]:g},{MOULD_CUTTER[1]:g}", "LOADTL/1",
              "SPINDL/10000,RPM,CLW"]
    n = write_apt(folder / "mould.apt", header, blocks, multax=False)
    write_cc_csv(folder / "cc.csv", [ps], 100)
    return {"part": part, "passes": [ps], "cutter": cutter, "goto": (n,)}


# ---- impeller passage (5-axis) ----------------------------------------------------------------
IMP_BLADES = 9                 # blades of the full wheel; the passage lies between two of them
IMP_PITCH = 2 * np.pi / IMP_BLADES
IMP_PROFILE = np.array([[28.0, 36.0], [32.0, 12.0], [58.0, 6.0]])  # hub meridian (r, z) Bezier
IMP_HEIGHT = 20.0              # mm, blade height along the hub normal
IMP_WRAP = np.radians(25.0)    # blade angle gained from inlet to outlet (wrap)
IMP_LEAN = np.radians(4.0)     # blade tip turned further on (+angle): over the passage at blade 0
IMP_HALF = 1.2                 # mm, half the blade thickness mid-chord
IMP_CUTTER = (6.0, 3.0)        # CUTTER/6,3: ball end-mill D6
IMP_ROWS, IMP_STATIONS = 7, 25  # CC rows across the passage, CC points along each (inlet -> outlet)
IMP_CLEAR = 4.5                # mm, ball's distance across the blade roots at the outer rows
IMP_MACHINE = "linuxcnc-xyzac-trt"


def _meridian(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hub meridian at Bezier parameters s (K,): points (K, 2) (r, z) and unit normals (K, 2)
    pointing out of the hub (outwards and up)."""
    s = np.asarray(s, float)[:, None]
    p0, p1, p2 = IMP_PROFILE
    pt = (1 - s) ** 2 * p0 + 2 * s * (1 - s) * p1 + s**2 * p2
    d = 2 * (1 - s) * (p1 - p0) + 2 * s * (p2 - p1)
    n = np.stack([-d[:, 1], d[:, 0]], axis=1)
    return pt, n / np.linalg.norm(n, axis=1, keepdims=True)


def _spin(rz: np.ndarray, ang: np.ndarray) -> np.ndarray:
    """Meridian points or vectors (K, 2) (r, z) at angles ang (K,) about Z: (K, 3)."""
    return np.stack([rz[:, 0] * np.cos(ang), rz[:, 0] * np.sin(ang), rz[:, 1]], axis=1)


def impeller_hub() -> NURBS.Surface:
    """The hub between the blades: the exact surface of revolution about Z of the quadratic
    meridian IMP_PROFILE (u: the meridian, inlet -> outlet; v: one rational quadratic arc over
    1.6 pitches, angle increasing), so that du x dv points out of the hub."""
    half = 0.8 * IMP_PITCH
    ang = 0.5 * IMP_PITCH + np.array([-half, 0.0, half])
    poles = np.empty((3, 3, 3))
    weights = np.empty((3, 3))
    for j in range(3):
        scale = 1.0 / np.cos(half) if j == 1 else 1.0
        rz = IMP_PROFILE * [scale, 1.0]
        poles[:, j] = _spin(rz, np.full(3, ang[j]))
        weights[:, j] = np.cos(half) if j == 1 else 1.0
    return _surface("hub", 2, 2, _clamped(2), _clamped(2), poles, weights)


def impeller_blade(k: int, side: int) -> NURBS.Surface:
    """One side (+1 suction, -1 pressure) of blade k (at angle k * IMP_PITCH): a ruled surface,
    cubic along the meridian (7 poles at s = 0 .. 1) and linear from 1.5 mm inside the hub to
    IMP_HEIGHT above it along the hub normal, its tip turned IMP_LEAN further about Z than its
    root (twisted). The sides are IMP_HALF apart mid-chord and meet at both edges. The suction
    side faces +angle, the pressure side -angle (du x dv out of the blade)."""
    s = np.linspace(0.0, 1.0, 7)
    rz, n = _meridian(s)
    thick = side * IMP_HALF * np.sin(np.pi * s) / rz[:, 0]
    ang = k * IMP_PITCH + IMP_WRAP * s**2 + thick
    root = _spin(rz - 1.5 * n, ang)
    tip = _spin(rz + IMP_HEIGHT * n, ang + IMP_LEAN)
    poles = np.stack([root, tip], axis=1)
    if side > 0:
        poles = poles[::-1]
    return _surface(f"blade{k}_{'suction' if side > 0 else 'pressure'}", 3, 1,
                    _clamped(3, (0.25, 0.5, 0.75)), _clamped(1), poles)


def impeller_surfaces() -> list[NURBS.Surface]:
    """Hub and the two blades bounding the passage (blade 0 leans over it, blade 1 away)."""
    return [impeller_hub()] + [impeller_blade(k, side) for k in (0, 1) for side in (-1, 1)]


def impeller_passes(cutter: Cutter) -> list[Pass]:
    """IMP_ROWS rows across the passage, each IMP_STATIONS CC points along the meridian (zig-zag),
    on the hub at IMP_CLEAR from the blade roots at the outer rows; the naive CAM's tool axis: the
    hub normal at the CC point."""
    s = np.linspace(0.04, 0.96, IMP_STATIONS)
    rz, n = _meridian(s)
    r = rz[:, 0]
    wrap = IMP_WRAP * s**2
    # IMP_CLEAR across the blade root, which runs obliquely over the hub (tan = r dθ / dm):
    # along the circle it is IMP_CLEAR / cos of that angle
    dm = np.linalg.norm(2 * (1 - s)[:, None] * (IMP_PROFILE[1] - IMP_PROFILE[0])
                        + 2 * s[:, None] * (IMP_PROFILE[2] - IMP_PROFILE[1]), axis=1)
    across = IMP_CLEAR * np.hypot(1.0, r * 2 * IMP_WRAP * s / dm)
    # the suction side of blade 0 and the pressure side of blade 1 at the root
    lo = wrap + IMP_HALF * np.sin(np.pi * s) / r + across / r
    hi = IMP_PITCH + wrap - IMP_HALF * np.sin(np.pi * s) / r - across / r
    out = []
    for i, f in enumerate(np.linspace(0.0, 1.0, IMP_ROWS)):
        ang = lo + f * (hi - lo)
        cc, nn = _spin(rz, ang), _spin(n, ang)
        if i % 2:
            cc, nn = cc[::-1], nn[::-1]
        out.append(Pass(cc, nn, nn.copy(), cutter.tip_from_contact(cc, nn, nn)))
    return out


def impeller_blocks(passes: list[Pass]) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Each row: rapid to 40 mm above its first CL point along its axis, plunge to 5 mm above
    it, cut, retract 40 mm along the last axis."""
    blocks = []
    for ps in passes:
        a0, a1 = ps.axes[0], ps.axes[-1]
        blocks.append(("rapid", (ps.tips[0] + 40.0 * a0)[None], a0[None]))
        blocks.append(("plunge", (ps.tips[0] + 5.0 * a0)[None], a0[None]))
        blocks.append(("feed", ps.tips, ps.axes))
        blocks.append(("rapid", (ps.tips[-1] + 40.0 * a1)[None], a1[None]))
    return blocks


def build_impeller(folder: Path) -> dict:
    """passage.json (hub + two blades), passage.apt (5-axis, ball D6 along the hub normal, for
    IMP_MACHINE) and cc.csv (its CC points)."""
    folder.mkdir(parents=True, exist_ok=True)
    part = write_part(impeller_surfaces(), folder / "passage.json")
    cutter = cutter_from_apt(list(IMP_CUTTER))
    passes = impeller_passes(cutter)
    header = ["PARTNO/IMPELLER PASSAGE HUB FINISH BALL D6 HUB NORMAL",
              f"PPRINT/MACHINE {IMP_MACHINE}", "UNITS/MM", "MULTAX",
              f"CUTTER/{IMP_CUTTER[0]:g},{IMP_CUTTER[1]:g}", "LOADTL/1", "SPINDL/12000,RPM,CLW"]
    n = write_apt(folder / "passage.apt", header, impeller_blocks(passes), multax=True)
    write_cc_csv(folder / "cc.csv", passes, IMP_ROWS * IMP_STATIONS)
    return {"part": part, "passes": passes, "cutter": cutter, "goto": (n,)}


# ---- flank milling (Gong and Wang 2009: a hyperbolic-paraboloid wall, cylinder D10) ---------
def build_flank(folder: Path) -> dict:
    """hypar.json (the wall y = x z / 100, x in [-30, 30], z in [0, 30], exact bilinear) and
    hypar.apt (a 5-axis flank pass of CUTTER/10,0,5,0,0,0,40 by the naive rule: axis along the
    21 rulings x = const, offset 5 mm along the normal at mid-height, tip 2 mm below the wall,
    entered and left along the axis;
    the envelope overcuts about 0.05 mm at the ends of the rulings, `pathcheck flank
    --optimise` brings it under 0.001 mm)."""
    from checker.flank.ruled import hyperbolic_paraboloid, naive_poses

    folder.mkdir(parents=True, exist_ok=True)
    k = [0.0, 0.0, 1.0, 1.0]
    wall = hyperbolic_paraboloid(30.0, 30.0, 100.0)
    part = write_part([_surface("hypar wall", 1, 1, k, k, wall.ctrlpts)], folder / "hypar.json")
    cutter = cutter_from_apt([10.0, 0.0, 5.0, 0.0, 0.0, 0.0, 40.0])
    tips, axes = naive_poses(part.surfaces[0], cutter, np.linspace(0.0, 1.0, 21), 2.0)
    a0, a1 = axes[0], axes[-1]
    blocks = [("rapid", (tips[0] + 45.0 * a0)[None], a0[None]),
              ("plunge", (tips[0] + 5.0 * a0)[None], a0[None]), ("feed", tips, axes),
              ("rapid", (tips[-1] + 45.0 * a1)[None], a1[None])]
    header = ["PARTNO/HYPERBOLIC PARABOLOID WALL FLANK CYLINDER D10", "UNITS/MM", "MULTAX",
              "CUTTER/10,0,5,0,0,0,40", "LOADTL/1", "SPINDL/10000,RPM,CLW"]
    n = write_apt(folder / "hypar.apt", header, blocks, multax=True)
    return {"part": part, "cutter": cutter, "tips": tips, "axes": axes, "goto": (n,)}


# ---- checks -----------------------------------------------------------------------------------
def dense_points(part: Part, n: int = 160) -> np.ndarray:
    """An n x n grid of points on every surface of the part (mm)."""
    t = np.linspace(0.0, 1.0, n)
    U, V = np.meshgrid(t, t)
    pts = []
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        pts.append(evaluate(s, u0 + (u1 - u0) * U.ravel(), v0 + (v1 - v0) * V.ravel()).points)
    return np.concatenate(pts)


def clearance(points: np.ndarray, core: Core, tips: np.ndarray, axes: np.ndarray,
              length: float) -> np.ndarray:
    """Smallest signed distance (K,) from the dense part points to each cutter (its cutting end
    and its shank up to `length` above the tip): every point within r + R + 1 mm of axis points
    spaced 1 mm apart is tested."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    out = np.full(len(tips), np.inf)
    for step in np.arange(core.h_o, length, 1.0):
        found = tree.query_ball_point(tips + step * axes, core.r + core.R + 1.0)
        counts = np.array([len(f) for f in found])
        if counts.sum() == 0:
            continue
        rows = np.repeat(np.arange(len(tips)), counts)
        idx = np.concatenate([np.asarray(f, dtype=np.int64) for f in found])
        np.minimum.at(out, rows, signed_distance(core, points[idx], tips[rows], axes[rows]))
    return out


def copy_warmup_job() -> None:
    """The demo job, copied into the package as the job `pathcheck warm` compiles with."""
    for suffix in (".apt", ".json"):
        data = (HERE / "compressor" / f"compressor_small_d12{suffix}").read_bytes()
        (resource("warmup") / f"warmup{suffix}").write_bytes(data)


def build_vise(folder: Path) -> Path:
    """`vise.stl`: the two jaws of a machine vise holding the mould's stock (`--stock box:+2`:
    X -82..82, Y -57..57, Z -25..2) by its Y faces, 10 mm below its top: each jaw 180 x 20 x
    25 mm (X -90..90, Y 57..77 and -77..-57, Z -33..-8), as a closed binary STL."""
    import stl
    from stl import mesh

    faces = np.array([(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
                      (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)])
    jaws = []
    for y0, y1 in ((57.0, 77.0), (-77.0, -57.0)):
        lo, hi = np.array([-90.0, y0, -33.0]), np.array([90.0, y1, -8.0])
        corners = np.array([[hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1],
                             hi[2] if i & 4 else lo[2]] for i in range(8)])
        jaws.append(corners[faces])
    vise = mesh.Mesh(np.zeros(24, dtype=mesh.Mesh.dtype))
    vise.vectors[:] = np.concatenate(jaws)
    folder.mkdir(parents=True, exist_ok=True)
    vise.save(str(folder / "vise.stl"), mode=stl.Mode.BINARY)
    return folder / "vise.stl"


def main() -> None:
    build_vise(HERE / "fixtures")
    comp = build_compressor(HERE / "compressor")
    mould = build_mould(HERE / "mould")
    impeller = build_impeller(HERE / "impeller")
    build_flank(HERE / "flank")
    copy_warmup_job()
    for name, res in (("compressor", comp), ("mould", mould), ("impeller", impeller)):
        pts = dense_points(res["part"])
        core = res["cutter"].core
        for ps in res["passes"]:
            c = clearance(pts, core, ps.tips, ps.axes, 60.0)
            print(f"{name}: {len(ps.tips)} CL points, GOTO {res['goto']}, clearance min "
                  f"{c.min():.6f} mm, max {c.max():.6f} mm")


if __name__ == "__main__":
    main()
