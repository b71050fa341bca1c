"""The machined part against the design, hooked into the stock's removal: the deviation after
each operation and at the end, the over-cut beyond the tolerance (a `gouge` as the machine
leaves it), the material left beyond tolerance + leave as rest-machining regions with the
largest cutter that finishes each (docs/MATH.md §15). Part frame, mm."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from checker import verdict as vd
from checker.machined.deviation import covered, error_bound, signed_deviation
from checker.machined.points import SurfaceMesh, surface_mesh
from checker.machined.regions import Region, regions
from checker.results import MachinedOperation, MachinedRegion, MachinedResult

MOST_POINTS = 250_000   # measuring points about at most: the spacing grows to keep within
REACH_CUT = 5.0         # mm: over-cuts are searched this deep along the inward normal
REACH_LEFT = 10.0       # mm: material left is followed this far along the outward normal
ADVISED = 20            # regions given a cutter at most (the largest)
LISTED = 100            # regions of each kind listed in the document at most (the largest)
PROBES = 64             # points per region the allowable size is found at
SIZE_TOL = 0.01         # mm: the allowable size's bisection (library sizes differ by more)


def stock_box(stock) -> np.ndarray:
    """(2, 2) mm: the x, y box of the stock's grid."""
    return np.array([[stock.x0, stock.y0],
                     [stock.x0 + stock.nx * stock.h, stock.y0 + stock.ny * stock.h]])


def measuring_spacing(V: np.ndarray, T: np.ndarray, h: float,
                      box: np.ndarray | None = None) -> float:
    """mm: 2 h, or coarser so the triangles' area within the x, y `box` (each triangle's area
    times the part of its bounding box inside) holds about MOST_POINTS points at most (the
    longest-edge split leaves about 6 points per spacing^2 of area)."""
    c = V[T]
    area = 0.5 * np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1)
    if box is not None:
        lo, hi = c.min(axis=1)[:, :2], c.max(axis=1)[:, :2]
        span = np.maximum(hi - lo, 1e-9)
        inside = np.clip(np.minimum(hi, box[1]) - np.maximum(lo, box[0]), 0.0, None)
        area = area * np.prod(np.where(hi - lo > 1e-9, inside / span,
                                       (lo >= box[0]) & (lo <= box[1])), axis=1)
    return max(2.0 * h, math.sqrt(6.0 * float(area.sum()) / MOST_POINTS))


def facing(normals: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(V,) bool: the normal is turned toward some tool axis of the job (or across it, a
    wall: n . a > -0.01); the others (the part's underside in a 3-axis job) no tool of it
    can finish, so they get no rest-machining advice."""
    a = np.unique(np.round(np.asarray(axes, float).reshape(-1, 3), 3), axis=0)[:1000]
    out = np.zeros(len(normals), bool)
    for row in a:
        out |= normals @ row > -0.01
    return out


class Comparison:
    """The deviation of the stock from the part (`triangles`: `PartTriangles`, `index` its
    `MeshIndex`) as the operations cut it; `cutters` and `tolerance` (K,) and `leave` (K,) per
    operation (mm), `along` the removal's bound along a ray (mm), `axes (A, 3)` the job's tool
    axes (default +Z), `out` the deviation file to write (`checker.machined.output`)."""

    def __init__(self, triangles, index, stock, cutters: dict, tolerance: np.ndarray,
                 leave: np.ndarray, along: float, *, axes: np.ndarray | None = None,
                 out: Path | None = None, spacing: float | None = None) -> None:
        t0 = time.perf_counter()
        self.index, self.cutters, self.out = index, cutters, out
        self.tolerance, self.leave = np.asarray(tolerance, float), np.asarray(leave, float)
        self.h, self.along = float(stock.h), float(along)
        box = stock_box(stock)
        V, T = triangles.vertices, triangles.triangles
        self.spacing = float(spacing or measuring_spacing(V, T, stock.h, box))
        self.mesh: SurfaceMesh = surface_mesh(V, T, triangles.surface, self.spacing, box)
        m = self.mesh
        self.bound = error_bound(self.along, self.h, m.normals)
        self.reachable = facing(m.normals, np.array([[0.0, 0.0, 1.0]]) if axes is None
                                else axes)
        self.reach_left = REACH_LEFT
        self.covered = covered(stock, m.vertices, m.normals, 2.0 * self.h)
        self.dev = np.full(len(m.vertices), np.nan)
        self.dev[self.covered] = self._deviation(stock)
        self.last_op = np.full(len(m.vertices), -1)
        self.ops: list[MachinedOperation] = []
        self.time = time.perf_counter() - t0

    def after(self, o: int, stock) -> None:
        """The deviation once operation `o` has cut `stock`."""
        t0 = time.perf_counter()
        dev = np.full(len(self.mesh.vertices), np.nan)
        dev[self.covered] = self._deviation(stock)
        cut = self.covered & (self.dev - dev > self.bound)
        self.last_op[cut] = o
        left = np.maximum(dev[cut], 0.0)
        over = -dev[self.covered]
        self.ops.append(MachinedOperation(
            op=o, points_cut=int(cut.sum()), left_max=float(left.max(initial=0.0)),
            left_mean=float(left.mean()) if left.size else 0.0, leave=float(self.leave[o]),
            overcut_max=float(max(over.max(initial=0.0), 0.0))))
        self.dev = dev
        self.time += time.perf_counter() - t0

    def _deviation(self, stock) -> np.ndarray:
        c = self.covered
        return signed_deviation(stock, self.mesh.vertices[c], self.mesh.normals[c],
                                self.reach_left, REACH_CUT)

    def result(self, library=None) -> MachinedResult:
        """The summary, the regions and the advice at the end; the deviation file written
        when asked (`out`)."""
        t0 = time.perf_counter()
        m, dev, cov = self.mesh, self.dev, self.covered
        done = self.last_op >= 0
        op = np.where(done, self.last_op, 0)
        tol = np.where(done, self.tolerance[op], self.tolerance.min(initial=0.0))
        leave = np.where(done, self.leave[op], 0.0)
        bound = error_bound(self.along, self.h, m.normals, dev)
        verdict = vd.decide_machined(-dev, tol, bound)
        gouge = cov & (verdict == "gouge")
        left = cov & self.reachable & (dev > tol + leave + bound)
        over_found = regions(m, gouge, -dev)
        over_regions = [self._region(i, r, "overcut", -dev)
                        for i, r in enumerate(over_found[:LISTED])]
        left_found = [r for r in regions(m, left, dev) if r.area >= self.spacing ** 2]
        left_regions = [self._region(i, r, "left", dev) for i, r in enumerate(left_found)]
        if library is not None and self.cutters:
            _finishing_tools(self, left_found[:ADVISED], left_regions[:ADVISED], library)
        res = MachinedResult(
            points=len(m.vertices), spacing=self.spacing, uncovered=int((~cov).sum()),
            bound_along=self.along, bound_max=float(bound.max(initial=self.along)),
            reach=REACH_CUT, left_max=float(max(dev[cov].max(initial=0.0), 0.0)),
            overcut_max=float(max((-dev[cov]).max(initial=0.0), 0.0)),
            gouge_points=int(gouge.sum()), left_points=int(left.sum()),
            overcut_regions=len(over_found), left_regions=len(left_found),
            overcut=over_regions, left=left_regions[:LISTED], advice=_advice(left_regions),
            operations=self.ops)
        if self.out is not None:
            from checker.machined.output import write_deviation

            written, picture = write_deviation(self.out, m, np.where(cov, dev, np.nan))
            res.deviation_file, res.picture = str(written), str(picture)
        self.time += time.perf_counter() - t0
        res.time_s = self.time
        return res

    def _region(self, i: int, r: Region, kind: str, value: np.ndarray) -> MachinedRegion:
        ops = self.last_op[r.vertices]
        ops = ops[ops >= 0]
        op = int(np.bincount(ops).argmax()) if ops.size else None
        return MachinedRegion(index=i, kind=kind, area=r.area, max=r.max, mean=r.mean,
                              point=tuple(map(float, self.mesh.vertices[r.at])),
                              vertices=int(r.vertices.size), op=op)


def _probes(c: Comparison, r: Region) -> np.ndarray:
    """Up to PROBES vertices of region `r` facing +Z: half its thickest, half spread over it."""
    v = r.vertices[c.mesh.normals[r.vertices, 2] > 1e-9]
    if v.size <= PROBES:
        return v
    thick = v[np.argsort(-c.dev[v], kind="stable")[: PROBES // 2]]
    spread = v[np.linspace(0, v.size - 1, PROBES - PROBES // 2).round().astype(int)]
    return np.unique(np.concatenate([thick, spread]))


def _finishing_tools(c: Comparison, found: list[Region], out: list[MachinedRegion],
                     library) -> None:
    """Per region: the least over its probes (`_probes`) of the largest size of its cutter's
    family touching there gouge-free with the axis +Z (`checker.mesh.allowable.allowable_on_mesh`,
    all regions of a cutter in one bisection), and the library's largest cutter not above
    it (`allowable`, `tool` of `out`)."""
    from checker.mesh.allowable import allowable_on_mesh

    cutter_of = [c.cutters[o.op if o.op is not None else max(c.cutters)] for o in out]
    for cutter in {id(k): k for k in cutter_of}.values():
        mine = [i for i, k in enumerate(cutter_of) if k is cutter]
        probes = [_probes(c, found[i]) for i in mine]
        rows = np.concatenate(probes) if probes else np.zeros(0, int)
        if rows.size == 0:
            continue
        r = None if cutter.ball_family else cutter.r
        family = library.family(cutter.kind, r)
        s_max = max([t.size for t in family] + [float(cutter.size)])
        o = out[mine[0]].op
        size = allowable_on_mesh(c.index, cutter, c.mesh.vertices[rows], c.mesh.normals[rows],
                                 np.array([0.0, 0.0, 1.0]),
                                 tol=max(float(c.tolerance[o or 0]), 1e-4), s_max=s_max,
                                 s_tol=SIZE_TOL)
        at = np.cumsum([0] + [len(p) for p in probes])
        for k, i in enumerate(mine):
            if at[k + 1] == at[k]:
                continue
            least = float(np.min(size[at[k]:at[k + 1]]))
            least = least if math.isfinite(least) else s_max
            tool = library.largest_not_exceeding(cutter.kind, least, r)
            out[i].allowable, out[i].tool = least, None if tool is None else tool.name


def _advice(left: list[MachinedRegion]) -> str | None:
    """"rest machining: 3 regions, 41 mm^2, up to 0.62 mm thick; largest safe tool BALL-D4"."""
    if not left:
        return None
    area = sum(r.area for r in left)
    thick = max(r.max for r in left)
    more = "+" if thick >= REACH_LEFT else ""         # followed no farther than REACH_LEFT
    text = (f"rest machining: {len(left)} region{'s' if len(left) > 1 else ''}, "
            f"{area:.3g} mm^2, up to {thick:.3g}{more} mm thick")
    sized = [r for r in left if r.allowable is not None]
    if sized:
        least = min(sized, key=lambda r: r.allowable)
        text += (f"; largest safe tool {least.tool}" if least.tool is not None else
                 f"; no tool of the library fits (allowable {least.allowable:.3g} mm)")
    return text
