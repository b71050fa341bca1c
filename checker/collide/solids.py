"""The solids of the machine check as `coal` geometries (the narrow phase, docs/MATH.md §16): the
machine's components (`checker.postproc.components`), the tool assembly per operation (its body,
shank and holder, `checker.mesh.tool`, each as its bounding cylinder: exact for a flat end, a
capsule for a ball), the part's triangles, the stock (box, cylinder or mesh) and the fixtures.
Each solid knows its link (`Links`), its side (the work: bed, table, part; the tool: ram, head,
spindle, tool, and bed components that move with linear axes), its placement in its link's
frame and a bounding sphere there (the broad phase). mm."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError


def _coal():
    from checker.extras import require

    require("coal", "machine", "the machine check (--machine-check)")
    import coal

    return coal


@dataclass
class Shape:
    """One coal geometry `geom` placed in its link's frame by `R0 (3, 3)`, `t0 (3,)`, inside the
    sphere `center (3,)` (link frame), `radius` mm."""

    geom: object
    R0: np.ndarray
    t0: np.ndarray
    center: np.ndarray
    radius: float


@dataclass
class Solid:
    """A solid of the check: `name`, `kind` ("machine", "tool", "part", "stock", "fixture"),
    `side` ("work" or "tool"), `link` ("table", j) or ("head", j) (j = 0: the bed or the ram),
    `moves (3,)` the linear axes moving a bed component (0/1), `gauge` whether it is given in the
    spindle frame (shifted up by the gauge length), its shape per operation (`shapes`, key None:
    every operation)."""

    name: str
    kind: str
    side: str
    link: tuple[str, int]
    shapes: dict = field(default_factory=dict)
    moves: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gauge: bool = False

    def shape(self, op) -> Shape | None:
        return self.shapes.get(op, self.shapes.get(None))


def _frame_to(axis: np.ndarray) -> np.ndarray:
    """A rotation taking +Z to unit `axis`."""
    z = axis / np.linalg.norm(axis)
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _mesh(vertices: np.ndarray, triangles: np.ndarray) -> Shape:
    coal = _coal()
    m = coal.BVHModelOBBRSS()
    m.beginModel(0, 0)
    m.addVertices(np.ascontiguousarray(vertices, dtype=float))
    m.addTriangles(np.ascontiguousarray(triangles, dtype=np.int64))
    m.endModel()
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    c = 0.5 * (lo + hi)
    return Shape(m, np.eye(3), np.zeros(3), c, float(np.linalg.norm(vertices - c, axis=1).max()))


def _frustum(r0: float, r1: float, p0: np.ndarray, p1: np.ndarray, sides: int = 32) -> Shape:
    """The convex hull of two circles, their polygons circumscribed (the hull holds the
    frustum)."""
    coal = _coal()
    R = _frame_to(p1 - p0)
    length = float(np.linalg.norm(p1 - p0))
    ang = 2.0 * np.pi * np.arange(sides) / sides
    grow = 1.0 / np.cos(np.pi / sides)
    ring = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(sides)]) * grow
    pts = [ring * r0] if r0 > 0 else [np.zeros((1, 3))]
    pts.append(ring * r1 + [0, 0, length] if r1 > 0 else np.array([[0.0, 0.0, length]]))
    pts = np.vstack(pts)
    m = coal.BVHModelOBBRSS()
    m.beginModel(0, 0)
    m.addVertices(pts)
    m.endModel()
    m.buildConvexHull(False, "Qt")
    mid = 0.5 * (p0 + p1)
    rad = float(np.hypot(max(r0, r1) * grow, 0.5 * length))
    return Shape(m.convex, R, p0, mid, rad)


def _cylinder(radius: float, p0: np.ndarray, p1: np.ndarray) -> Shape:
    coal = _coal()
    length = float(np.linalg.norm(p1 - p0))
    mid = 0.5 * (p0 + p1)
    return Shape(coal.Cylinder(radius, length), _frame_to(p1 - p0), mid, mid,
                 float(np.hypot(radius, 0.5 * length)))


def _box(lo, hi) -> Shape:
    coal = _coal()
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = 0.5 * (lo + hi)
    return Shape(coal.Box(*(hi - lo)), np.eye(3), c, c, float(0.5 * np.linalg.norm(hi - lo)))


def component_shape(comp, cfg) -> Shape:
    """The coal shape of a machine component (`checker.postproc.components.Component`)."""
    if comp.box is not None:
        return _box(comp.box.min, comp.box.max)
    if comp.cylinder is not None:
        c = comp.cylinder
        return _cylinder(c.radius, np.asarray(c.start, float), np.asarray(c.end, float))
    if comp.cone is not None:
        c = comp.cone
        return _frustum(c.radius_start, c.radius_end, np.asarray(c.start, float),
                        np.asarray(c.end, float))
    from checker.stock.solid import load_solid

    path = Path(comp.mesh)
    if not path.is_file():
        raise PathcheckError(f"machine component '{comp.name}': mesh file not found, expected "
                             "an STL beside the machine file", path=path, code="machine")
    vertices, triangles = load_solid(path, cfg, what="machine component")
    return _mesh(vertices, triangles)


def machine_solids(machine, cfg) -> list[Solid]:
    """The machine's components as solids (module docstring)."""
    table = [a.name for a in machine.rotary_axes if a.on == "table"]
    head = [a.name for a in machine.rotary_axes if a.on == "head"]
    out = []
    for comp in machine.components:
        shape = component_shape(comp, cfg)
        if comp.link == "bed" or comp.link in table:
            j = 0 if comp.link == "bed" else table.index(comp.link) + 1
            moves = np.array([float(a in (comp.moves or "")) for a in "xyz"])
            out.append(Solid(comp.name, "machine", "tool" if moves.any() else "work",
                             ("table", j), {None: shape}, moves))
        else:
            j = {"ram": 0, "spindle": len(head)}.get(comp.link)
            j = head.index(comp.link) + 1 if j is None else j
            out.append(Solid(comp.name, "machine", "tool", ("head", j), {None: shape},
                             gauge=True))
    return out


def tool_solid(cutters: dict, n_head: int) -> list[Solid]:
    """The tool assembly of every operation (`cutters`: op -> Cutter) as up to three solids
    (body, shank, holder) on the last head link, tip frame: each piece's bounding cylinder
    (a ball's body: its capsule). A body of unknown length ends where the shank or the holder
    starts, else at four diameters."""
    from checker.mesh.tool import UNBOUNDED, tool_pieces

    coal = _coal()
    names = ("tool body", "tool shank", "tool holder")
    solids = [Solid(n, "tool", "tool", ("head", n_head)) for n in names]
    for o, cutter in cutters.items():
        pieces = tool_pieces(cutter, with_holder=True)
        for p in range(len(pieces)):
            prof = pieces.prof[p, : pieces.nprof[p]]
            rho = float(pieces.rho[p])
            r = float(prof[:, 0].max()) + rho
            h0 = max(float(prof[:, 1].min()) - rho, 0.0)
            h1 = float(prof[:, 1].max()) + rho
            if h1 >= 0.5 * UNBOUNDED:
                h1 = (float(pieces.prof[p + 1, 0, 1]) if p + 1 < len(pieces)
                      else max(4.0 * float(cutter.d), h0 + 1.0))
            lo, hi = np.array([0.0, 0.0, h0]), np.array([0.0, 0.0, h1])
            kind = int(pieces.kind[p])
            if kind == 0 and float(prof[:, 0].max()) < 1e-9 and rho > 0:  # a ball: capsule
                a, b = float(prof[:, 1].min()), min(float(prof[:, 1].max()), h1 - rho)
                mid = np.array([0.0, 0.0, 0.5 * (a + b)])
                shape = Shape(coal.Capsule(rho, max(b - a, 1e-9)), np.eye(3), mid, mid,
                              rho + 0.5 * (b - a))
            else:
                shape = _cylinder(r, lo, hi)
            solids[kind].shapes[int(o)] = shape
    return [s for s in solids if s.shapes]


def work_solids(triangles, stock_shape, fixtures, n_table: int) -> list[Solid]:
    """The part (its triangles, part frame), the stock (`checker.stock.spec` Box, Cylinder or a
    solid's (vertices, triangles)) and the fixtures (`checker.stock.fixtures.Fixture`) as solids
    on the last table link, part frame (the setup is applied with the link)."""
    out = []
    link = ("table", n_table)
    if triangles is not None:
        out.append(Solid("part", "part", "work", link,
                         {None: _mesh(triangles.vertices, triangles.triangles)}))
    if stock_shape is not None:
        out.append(Solid("stock", "stock", "work", link, {None: stock_shape}))
    for fx in fixtures:
        out.append(Solid(fx.name, "fixture", "work", link, {None: _mesh(fx.vertices,
                                                                       fx.triangles)}))
    return out


def stock_shape(shape) -> Shape:
    """A resolved stock (`checker.stock.spec`: Box, Cylinder, or a path to a solid)."""
    from checker.stock.spec import Box, Cylinder

    if isinstance(shape, Box):
        return _box(shape.lo, shape.hi)
    if isinstance(shape, Cylinder):
        k = "xyz".index(shape.axis)
        p0 = np.zeros(3)
        p0[[i for i in range(3) if i != k]] = np.asarray(shape.centre, float)
        p1 = p0.copy()
        p0[k], p1[k] = shape.start, shape.end
        return _cylinder(shape.radius, p0, p1)
    raise TypeError(shape)
