"""The program against the stock and the fixtures: the stock's material removed move by move,
operation by operation in program order, by the real tool (body, shank, holder: the check's own
solid, `checker.mesh.tool`) along the motion the machine makes; each move judged by the one
verdict rule (`checker.verdict.decide_stock`, `decide_fixture`); air cuts and the material
removed counted per operation (docs/MATH.md §14). Part frame, mm."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from checker import input_limits
from checker import verdict as vd
from checker.errors import PathcheckError
from checker.mesh.tool import tool_pieces
from checker.moves import FEED, RAPID, START, Moves
from checker.progress import step
from checker.results import (
    MoveEngagement,
    StockFinding,
    StockOperation,
    StockResult,
    verdict_counts,
)
from checker.stock.dexels import Dexels
from checker.stock.fixtures import Fixture, load_fixture
from checker.stock.removal_items import sweep_items
from checker.stock.request import StockRequest
from checker.toolpath import MotionArrays
from checker.verify import ProgramMotion, tool_depths

_PIECES = ("body", "shank", "holder")


@dataclass
class StockCheck:
    """Per pose of the written program (the move that reaches it): the verdict against the
    stock and every fixture (`verdict`, the worst), its `depth` and what it was against
    (`against`: "stock" or a fixture's name, '' none); the document's `result`."""

    verdict: np.ndarray
    depth: np.ndarray
    against: np.ndarray
    result: StockResult


def build_stock(request: StockRequest, part_box: np.ndarray | None, part_points, toolpath,
                cfg) -> tuple[Dexels, str]:
    """(Dexels, one sentence saying what the stock is and where it came from) of the stock
    asked, at the resolution asked or the default for its size (`default_resolution`); a model
    beyond `input_limits.MAX_STOCK_RAYS` rays is refused."""
    from checker.stock.removal import default_resolution
    from checker.stock.solid import load_solid, require_closed, solid_dexels
    from checker.stock.spec import Box, Cylinder, FromCL, parse_stock, resolve
    from checker.stock.stated import stated_stock

    spec = parse_stock(request.stock)
    try:
        shape = resolve(spec, part_box, stated_stock(toolpath), part_points=part_points)
    except PathcheckError as err:
        if not isinstance(spec, FromCL):
            raise
        raise PathcheckError(err.message, path=toolpath.path, code=err.code) from None
    if isinstance(shape, Box):
        lo, hi = np.asarray(shape.lo, float), np.asarray(shape.hi, float)
        h = _resolution(request, hi - lo, default_resolution)
        return Dexels.box(lo, hi, h), shape.how
    if isinstance(shape, Cylinder):
        ext = np.full(3, 2.0 * shape.radius)
        ext["xyz".index(shape.axis)] = shape.end - shape.start
        h = _resolution(request, ext, default_resolution)
        return (Dexels.cylinder(shape.axis, np.asarray(shape.centre, float), shape.radius,
                                shape.start, shape.end, h), shape.how)
    vertices, triangles = load_solid(Path(shape.path), cfg)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    h = _resolution(request, hi - lo, default_resolution)
    nx, ny = (int(np.ceil((hi[k] - lo[k]) / h)) + 1 for k in (0, 1))
    stock = solid_dexels(vertices, triangles, lo[0] - 0.5 * h, lo[1] - 0.5 * h, nx, ny, h)
    require_closed(stock, shape.path)
    return stock, shape.how


def _resolution(request: StockRequest, extent: np.ndarray, default) -> float:
    """The ray spacing: asked, else the default for `extent (3,)`; refused when the model
    would hold more rays than `MAX_STOCK_RAYS`."""
    h = float(request.resolution or default(extent))
    rays = float(np.ceil(max(extent[0], h) / h) + 1) * float(np.ceil(max(extent[1], h) / h) + 1)
    if rays > input_limits.MAX_STOCK_RAYS:
        raise PathcheckError(
            f"--stock-resolution {h:g} mm: the stock ({extent[0]:g} x {extent[1]:g} mm) would "
            f"need {rays:,.0f} rays; expected at most {input_limits.MAX_STOCK_RAYS:,} "
            "(a coarser resolution)", code="usage")
    return h


def _stock_box(stock: Dexels) -> np.ndarray:
    """(2, 3) the box of the stock's rays and material: the tool points that can cut it."""
    filled = stock.count > 0
    zlo = float(stock.bottom()[filled].min(initial=np.inf))
    zhi = float(stock.top()[filled].max(initial=-np.inf))
    return np.array([[stock.x0, stock.y0, zlo],
                     [stock.x0 + stock.nx * stock.h, stock.y0 + stock.ny * stock.h, zhi]])


def _ops_in_order(op_of: np.ndarray) -> list[int]:
    _, first = np.unique(op_of, return_index=True)
    return [int(op_of[i]) for i in np.sort(first)]


class _Program(NamedTuple):
    """What every part of the stage reads: the poses and moves, their motion rows, which are
    rapid (a cycle's retract is not), the tolerance per pose and each operation's tool."""

    moves: Moves
    m: MotionArrays
    rapid: np.ndarray
    tolerance: np.ndarray
    pieces: dict


@dataclass
class _Verdicts:
    """Per pose the worst verdict so far against the stock and the fixtures, its depth and
    what it was against; the findings in the order found."""

    verdict: np.ndarray
    depth: np.ndarray
    against: np.ndarray
    findings: list[StockFinding] = field(default_factory=list)

    @staticmethod
    def none(n: int) -> _Verdicts:
        return _Verdicts(np.full(n, "ok", dtype=object), np.zeros(n),
                         np.full(n, "", dtype=object))

    def merge(self, verdict: np.ndarray, depth: np.ndarray, against: str) -> None:
        """Take the verdicts that rank above those so far."""
        worse = _worse(verdict, self.verdict)
        self.verdict[worse], self.depth[worse], self.against[worse] = (
            verdict[worse], depth[worse], against)


@dataclass
class _Removed:
    """Per pose (the move that reaches it) what each piece removed (`checker.stock.removal`:
    `thickness`, `where`, `volume` per piece, the body's `width`) and per operation its
    summary."""

    thickness: np.ndarray
    where: np.ndarray
    volume: np.ndarray
    width: np.ndarray
    operations: list[StockOperation] = field(default_factory=list)

    @staticmethod
    def none(n: int) -> _Removed:
        return _Removed(np.zeros((n, 3)), np.full((n, 3, 3), np.nan), np.zeros((n, 3)),
                        np.zeros(n))


def check_stock(job, motion: ProgramMotion, cutters: dict, tol, request: StockRequest,
                part_box: np.ndarray | None) -> StockCheck:
    """The written program's `motion` against the stock and the fixtures of `request`, the
    operations' `cutters` and tolerances `tol` (`checker.tolerance`)."""
    t0 = time.perf_counter()
    moves, m = motion.moves, job.m
    rapid = ((moves.kind == RAPID) & ~moves.retract) | ((moves.kind == START) & m.rapid[moves.row])
    program = _Program(moves, m, rapid, tol.value[motion.op_of],
                       {o: tool_pieces(cutters[o], with_holder=True)
                        for o in np.unique(motion.op_of)})
    verdicts = _Verdicts.none(len(moves))
    base = dict(stock="none", resolution=0.0, error_bound=0.0, volume_initial=0.0,
                volume_final=0.0)
    if request.stock is not None:
        base = _against_stock(job, program, motion, cutters, tol, request, part_box, verdicts)
    fixtures = [load_fixture(text, job.cfg) for text in request.fixtures]
    for fx in fixtures:
        _against_fixture(fx, program, motion, job.cfg.check.reach, verdicts)
    result = StockResult(**base, fixtures=[f.name for f in fixtures],
                         counts=verdict_counts(verdicts.verdict), findings=verdicts.findings,
                         time_s=time.perf_counter() - t0)
    return StockCheck(verdicts.verdict, verdicts.depth, verdicts.against, result)


def _against_stock(job, program: _Program, motion: ProgramMotion, cutters: dict, tol,
                   request: StockRequest, part_box, verdicts: _Verdicts) -> dict:
    """The stock built, cut operation by operation, each move judged (`decide_stock`) into
    `verdicts`; the stock's fields of the document."""
    from checker.stock.removal import error_bound

    part_points = None if job.triangles is None else job.triangles.vertices
    stock, what = build_stock(request, part_box, part_points, job.toolpath, job.cfg)
    step_mm = stock.h  # poses of a turning move one ray apart: the bound step / 2
    bound = float(error_bound(stock.h, step_mm)[0])
    out_dir = None if request.stock_out is None else Path(request.stock_out)
    if out_dir is not None:  # the folder asked for, made once the stock is known
        from checker.atomic import make_parent

        make_parent(out_dir / "stock_final.stl", "stock STL")
    volume0 = stock.volume()
    design = _comparison(job, stock, cutters, tol, request, bound)
    removed = _remove(stock, program, motion, step_mm, out_dir, design)
    v, piece = vd.decide_stock(removed.thickness, program.rapid, program.tolerance)
    verdicts.merge(v, removed.thickness.max(axis=1), "stock")
    for i in np.flatnonzero(vd.is_finding(v)):
        p = int(piece[i])
        verdicts.findings.append(_finding(len(verdicts.findings), str(v[i]), "stock", i, program,
                                          p, float(removed.thickness[i, p]),
                                          removed.where[i, p]))
    final = None
    if out_dir is not None:
        from checker.stock.mesh_out import write_stl

        final = str(write_stl(stock, out_dir / "stock_final.stl"))
    return dict(stock=what, resolution=stock.h, error_bound=bound, volume_initial=volume0,
                volume_final=stock.volume(), operations=removed.operations,
                engagement=_engagement(program, removed), overflow=int(stock.overflow),
                final_stl=final,
                machined=None if design is None else design.result(_library()))


def _remove(stock: Dexels, program: _Program, motion: ProgramMotion, step_mm: float,
            out_dir: Path | None, design) -> _Removed:
    """Cut `stock` by every operation in program order (`checker.stock.removal.remove` on the
    items of `checker.stock.removal_items.sweep_items`): what each move removed, and each
    operation's summary (its stock written to `out_dir`, compared by `design`)."""
    from checker.stock.removal import remove

    moves = program.moves
    n = len(moves)
    box = _stock_box(stock)
    out = _Removed.none(n)
    with step("remove the stock", len(np.unique(motion.op_of))) as advance:
        for o in _ops_in_order(motion.op_of):
            P = np.flatnonzero(motion.op_of == o)
            items = sweep_items(moves, P, box, step_mm, motion.table(P[moves.kind[P] != START]),
                                motion.center, motion.machine(o))
            got = remove(stock, program.pieces[o], items.a, items.b, items.axis, items.move, n,
                         step=step_mm)
            out.thickness[P], out.where[P] = got.thickness[P], got.where[P]
            out.volume[P], out.width[P] = got.volume[P], got.width[P]
            out.operations.append(_operation(o, P, program, out, out_dir, stock))
            if design is not None:
                design.after(o, stock)
            advance(1)
    return out


def _engagement(program: _Program, removed: _Removed) -> MoveEngagement:
    """Per feed move what the body removed: volume, engaged depth and width."""
    feed = np.flatnonzero((program.moves.kind == FEED) & ~program.rapid)
    rows = program.moves.row[feed]
    return MoveEngagement(move=rows.tolist(), line=program.m.line[rows].tolist(),
                          volume=np.round(removed.volume[feed, 0], 6).tolist(),
                          depth=np.round(removed.thickness[feed, 0], 6).tolist(),
                          width=np.round(removed.width[feed], 6).tolist())


def _comparison(job, stock: Dexels, cutters: dict, tol, request: StockRequest, along: float):
    """The machined part against the design as the operations cut (`checker.machined`), or
    None without a part."""
    if getattr(job, "triangles", None) is None:
        return None
    from checker.machined.compare import Comparison
    from checker.machined.leave import operation_leave

    with step("compare the stock with the part"):
        return Comparison(job.triangles, job.index, stock, cutters, tol.value,
                          operation_leave(job.toolpath, request.leave), along,
                          axes=job.m.axis, out=request.deviation_out)


def _library():
    from checker.tool_library import load_tool_library

    return load_tool_library()


_RANK = {"ok": 0, "within_tolerance": 1, "holder": 2, "crash": 3}


def _worse(new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """(N,) bool: `new` verdicts that rank above `old` ones."""
    rank = np.vectorize(lambda v: _RANK.get(v, 0), otypes=[int])
    return rank(new) > rank(old)


def _operation(o: int, P: np.ndarray, program: _Program, removed: _Removed,
               out_dir: Path | None, stock: Dexels) -> StockOperation:
    """The operation's removed volume, air cuts and engagement; its stock written when asked."""
    moves, thick = program.moves, removed.thickness
    ends = P[moves.kind[P] == FEED]
    air = ends[thick[ends].max(axis=1) <= program.tolerance[ends]]
    length = np.linalg.norm(moves.tip[air] - moves.tip[air - 1], axis=1)
    feed = program.m.feed[moves.row[air]]
    timed = np.isfinite(feed) & (feed > 0)
    stl = None
    if out_dir is not None:
        from checker.stock.mesh_out import write_stl

        stl = str(write_stl(stock, out_dir / f"stock_op{o + 1:02d}.stl"))
    return StockOperation(
        op=o, removed=float(removed.volume[P, 0].sum()), feed_moves=int(ends.size),
        air_cuts=int(air.size), air_length=float(length.sum()),
        air_time_s=float((60.0 * length[timed] / feed[timed]).sum()) if timed.any() else None,
        depth_max=float(thick[ends, 0].max(initial=0.0)),
        width_max=float(removed.width[ends].max(initial=0.0)), stl=stl)


def _finding(index: int, verdict: str, against: str, i: int, program: _Program, piece: int,
             depth: float, point) -> StockFinding:
    """The finding of pose `i` (the move that reaches it)."""
    row = int(program.moves.row[i])
    pt = None if point is None or not np.isfinite(point).all() else tuple(map(float, point))
    return StockFinding(index=index, verdict=verdict, against=against, move=row,
                        line=int(program.m.line[row]), op=int(program.m.op[row]),
                        rapid=bool(program.rapid[i]),
                        piece=_PIECES[piece] if piece >= 0 else None, depth=depth,
                        tolerance=float(program.tolerance[i]),
                        tip=tuple(map(float, program.moves.tip[i])), point=pt)


def _against_fixture(fx: Fixture, program: _Program, motion: ProgramMotion, reach: float,
                     verdicts: _Verdicts) -> None:
    """The tool against fixture `fx` at every pose and along every move (a move's deepest pose
    counts at the pose it reaches), judged by `decide_fixture` into `verdicts`."""
    box = fx.box + [[-reach], [reach]]
    with step(f"check against the fixture {fx.name}"):
        poses, along = tool_depths(fx.index, box, motion, program.pieces, program.tolerance,
                                   reach)
    deepest = poses.depth.copy()
    at = np.full(len(program.moves), -1)
    more = along.depths.depth > deepest[along.end]
    deepest[along.end[more]] = along.depths.depth[more]
    at[along.end[more]] = np.flatnonzero(more)
    v = vd.decide_fixture(deepest, program.tolerance)
    verdicts.merge(v, deepest, fx.name)
    for i in np.flatnonzero(vd.is_finding(v)):
        k = at[i]
        piece = int(poses.piece[i] if k < 0 else along.depths.piece[k])
        point = poses.point[i] if k < 0 else along.depths.point[k]
        verdicts.findings.append(_finding(len(verdicts.findings), str(v[i]), fx.name, int(i),
                                          program, piece, float(deepest[i]), point))
