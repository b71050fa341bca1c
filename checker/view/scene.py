"""The scene of the 3-D view, built from a results document and the job's files: the part's
triangles (decimated), the tool path as one polyline with a kind per segment (rapid, feed, or the
verdict of a finding at the move's end), the findings with their pose and the real tool of their
operation, the tool axes of multi-axis jobs (the written one and, where re-oriented, the CAM's)
and, when the caller gives them, the stock after each operation and the fixtures.

Part frame, mm. Numeric arrays are little-endian base64 (`float32` positions, `uint32`
indices, `uint8` kinds) so that the page stays small and parses fast."""

from __future__ import annotations

import base64
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from checker.results import ResultsDocument
from checker.verdict import FINDINGS
from checker.view.decimate import decimate
from checker.view.tool_outline import tool_outlines

RAPID, FEED = 0, 1          # segment kinds; a finding's verdict is 2 + its index in FINDINGS
KINDS = ("rapid", "feed", *FINDINGS)
PART_TRIANGLES = 60_000      # the part decimated to at most this many triangles
STOCK_TRIANGLES = 120_000    # all the stock meshes together
FIXTURE_TRIANGLES = 30_000   # each fixture
AXIS_SAMPLES = 1_500         # tool axes drawn along a multi-axis path at most
TABLE_ROWS = 300             # rows of the findings table (every finding has its marker)
REORIENTED_ROWS = 100        # rows of the re-oriented poses table
REORIENTED_DEG = 0.1         # a written axis this far from the CAM's is a re-oriented pose
NURBS_DEVIATION = 0.05       # mm: exact surfaces tessellated this close for the view

Mesh = tuple[str, np.ndarray, np.ndarray]  # (label, vertices (V, 3) mm, triangles (T, 3))


def b64(array: np.ndarray, dtype: str) -> str:
    """`array` as little-endian `dtype` bytes, base64."""
    return base64.b64encode(np.ascontiguousarray(array, dtype=np.dtype(dtype).newbyteorder("<"))
                            .tobytes()).decode("ascii")


def _mesh(label: str, vertices: np.ndarray, triangles: np.ndarray, most: int) -> dict:
    v, t, cell = decimate(vertices, triangles, most)
    return {"label": label, "positions": b64(v, "f4"), "index": b64(t, "u4"),
            "vertices": len(v), "triangles": len(t), "cell": cell}


def _deviation_colours(mesh: dict, vertices: np.ndarray, deviation) -> None:
    """The machined stock coloured by the deviation to the design: each vertex of `mesh` (the
    decimated stock) takes the signed deviation (mm; + material left, - over-cut) of the
    nearest of the part's measuring points `deviation = (points (N, 3), values (N,))`
    (`checker.machined`), as `deviation` (f4, base64) beside `positions`."""
    from pykdtree.kdtree import KDTree

    points, values = (np.asarray(a) for a in deviation)
    ok = np.isfinite(values)
    if not ok.any():
        return
    _, near = KDTree(np.ascontiguousarray(points[ok], float)).query(
        np.ascontiguousarray(vertices, float), k=1)
    mesh["deviation"] = b64(values[ok][near], "f4")


def read_deviation(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 3), deviation (N,)) of a binary PLY that `--deviation-out` wrote
    (`checker.machined.output`: x, y, z, nx, ny, nz, deviation as little-endian floats)."""
    raw = Path(path).read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    head = raw[:end].decode("ascii").splitlines()
    n = int(next(line.split()[2] for line in head if line.startswith("element vertex")))
    vert = np.frombuffer(raw, dtype=[("p", "<f4", 3), ("n", "<f4", 3), ("d", "<f4")], count=n,
                         offset=end)
    return vert["p"].astype(float), vert["d"].astype(float)


def _resolve(name: str | None, beside: Path | None) -> Path | None:
    """`name` as given when it exists, else beside the results document."""
    if name is None:
        return None
    p = Path(name)
    if p.exists() or beside is None:
        return p
    q = beside / p.name
    return q if q.exists() else p


def part_mesh(doc: ResultsDocument, beside: Path | None = None, config=None) -> Mesh | None:
    """The document's part as triangles, in the frame it was checked in (its `part_transform`
    applied): an STL's own, exact surfaces tessellated within NURBS_DEVIATION; None without a
    part."""
    from checker.check.inputs import job_config
    from checker.geometry import load_part
    from checker.geometry.tessellate import part_triangles

    path = _resolve(doc.job.part, beside)
    if path is None:
        return None
    cfg = job_config(config)
    part = load_part(path, geometry=cfg.geometry)
    tris = part_triangles(part, max(NURBS_DEVIATION, cfg.check.part_deviation), cfg.geometry)
    v = np.asarray(tris.vertices, float)
    if doc.job.part_transform is not None:
        M = np.asarray(doc.job.part_transform, float).reshape(3, 4)
        v = v @ M[:, :3].T + M[:, 3]
    return path.name, v, np.asarray(tris.triangles)


def read_toolpath(doc: ResultsDocument, beside: Path | None = None,
                  machine: str | None = None):
    """The program the document was checked from (`job.path`): a CL file, or a G-code program
    (`job.dialect` "gcode") brought back into the part frame on `machine` (default the
    document's `job.machine`) as `pathcheck check-gcode` reads it by default (block delete on,
    the machine's units until G20/G21)."""
    from checker.apt import read_cl
    from checker.errors import PathcheckError

    path = _resolve(doc.job.path, beside)
    if doc.job.dialect != "gcode":
        return read_cl(path)
    machine = machine or doc.job.machine
    if machine is None:
        raise PathcheckError("a G-code program's results name no machine: expected --machine "
                             "NAME|FILE, the machine it was checked for", path=doc.job.path,
                             code="usage")
    from checker.postproc.machine import load_machine
    from checker.postproc.reader import read_gcode
    from checker.postproc.replay import part_motions, toolpath_of

    mach = load_machine(machine)
    moves = read_gcode(path, mach.dialect, units=mach.units, block_delete=True)
    return toolpath_of(part_motions(moves, mach), path=path, units=moves.units, cutter=None)


def _cutters(doc: ResultsDocument, toolpath, ops: np.ndarray, cutter) -> dict:
    """The real cutter of each operation: the one the check was given, else the CL file's,
    else the document's statement."""
    from checker.check.inputs import operation_cutters
    from checker.cutter import parse_cutter
    from checker.errors import PathcheckError

    try:
        return operation_cutters(toolpath, ops, cutter, Path(doc.job.path), doc.job.units)
    except PathcheckError:
        stated = {o.index: o.cutter for o in doc.operations}
        return {int(o): parse_cutter(stated.get(int(o), doc.job.cutter)) for o in ops}


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cos = np.clip(np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1)
                                                 * np.linalg.norm(b, axis=1)), -1.0, 1.0)
    return np.degrees(np.arccos(cos))


def _findings(doc: ResultsDocument, m) -> list[dict]:
    """Every finding of the written program (its poses, then against the stock and fixtures):
    where the marker goes (`at`: the part's deepest point, else the tool tip), the pose and
    the line."""
    out = []
    for p in doc.points:
        if p.verdict in FINDINGS:
            out.append({"index": p.index, "kind": p.kind, "verdict": p.verdict, "line": p.line,
                        "op": p.op, "move": p.move, "tip": list(p.tip), "axis": list(p.axis),
                        "at": list(p.point if p.point is not None else p.tip),
                        "depth": p.depth, "piece": p.piece, "rapid": p.rapid,
                        "against": "part"})
    if doc.stock is not None:
        for f in doc.stock.findings:
            axis = m.axis[f.move].tolist() if 0 <= f.move < len(m) else [0.0, 0.0, 1.0]
            out.append({"index": f.index, "kind": "stock" if f.against == "stock" else
                        "fixture", "verdict": f.verdict, "line": f.line, "op": f.op,
                        "move": f.move, "tip": list(f.tip), "axis": axis,
                        "at": list(f.point if f.point is not None else f.tip),
                        "depth": f.depth, "piece": f.piece, "rapid": f.rapid,
                        "against": f.against})
    return out


def _markers(findings: list[dict]) -> dict:
    """Every finding's marker and pose as arrays (`at`, `tip`, `axis` float32 (F, 3); `verdict`
    uint8 index into FINDINGS; `line` int32, -1 unknown; `op` uint16; `index` uint32 in its
    list) and the table's rows: the TABLE_ROWS deepest findings, each with its `marker`."""
    rank = {v: k for k, v in enumerate(FINDINGS)}
    depth = np.array([np.nan if f["depth"] is None else f["depth"] for f in findings], float)
    order = np.argsort(-np.nan_to_num(depth, nan=-np.inf), kind="stable")[:TABLE_ROWS]
    rows = [dict(findings[i], marker=int(i)) for i in order]

    def col(key: str) -> np.ndarray:
        return np.array([f[key] for f in findings], float).reshape(-1, 3)

    return {"count": len(findings), "at": b64(col("at"), "f4"), "tip": b64(col("tip"), "f4"),
            "axis": b64(col("axis"), "f4"),
            "verdict": b64(np.array([rank[f["verdict"]] for f in findings], np.uint8), "u1"),
            "line": b64(np.array([-1 if f["line"] is None else f["line"] for f in findings],
                                 np.int64), "i4"),
            "op": b64(np.array([f["op"] for f in findings], np.int64), "u2"),
            "index": b64(np.array([f["index"] for f in findings], np.int64), "u4"),
            "rows": rows}


def _segment_kinds(m, findings: list[dict]) -> np.ndarray:
    """(N - 1,) uint8: the kind of the segment from row i to row i + 1 (module constants); a
    segment that ends at a finding's move takes the worst verdict there."""
    kinds = np.where(np.asarray(m.rapid[1:], bool), RAPID, FEED).astype(np.uint8)
    rank = {v: k for k, v in enumerate(FINDINGS)}
    move = np.array([f["move"] for f in findings], np.int64)
    code = np.array([2 + rank[f["verdict"]] for f in findings], np.uint8)
    keep = (move >= 1) & (move < len(m))
    worst = np.zeros(len(kinds), np.uint8)
    np.maximum.at(worst, move[keep] - 1, code[keep])
    return np.where(worst > 0, worst, kinds).astype(np.uint8)


def _reoriented(doc: ResultsDocument, m) -> list[dict]:
    """Poses at CL records whose written axis differs from the CAM's (the CL file's) by more
    than REORIENTED_DEG, the most re-oriented first."""
    pts = [p for p in doc.points if p.kind == "cl" and 0 <= p.move < len(m)]
    if not pts:
        return []
    written = np.array([p.axis for p in pts], float)
    cam = m.axis[[p.move for p in pts]]
    ang = _angle_deg(written, cam)
    order = np.argsort(-ang, kind="stable")
    order = order[ang[order] > REORIENTED_DEG]
    return [{"index": pts[i].index, "line": pts[i].line, "op": pts[i].op,
             "verdict": pts[i].verdict, "tip": list(pts[i].tip), "axis": list(pts[i].axis),
             "cam": cam[i].tolist(), "cam_tip": m.tip[pts[i].move].tolist(),
             "angle": round(float(ang[i]), 3)} for i in order]


def written_path(doc: ResultsDocument, m) -> tuple[np.ndarray, np.ndarray]:
    """(tip (N, 3), axis (N, 3)) of each motion row as the program is written: the document's
    pose at its CL records (a re-oriented pose moves the tip too), the CL file's (the CAM's)
    elsewhere."""
    tip, axis = np.array(m.tip, float), np.array(m.axis, float)
    rows = [p for p in doc.points if p.kind == "cl" and 0 <= p.move < len(m)]
    if rows:
        at = [p.move for p in rows]
        tip[at] = [p.tip for p in rows]
        axis[at] = [p.axis for p in rows]
    return tip, axis


def _axes(m, tip: np.ndarray, written: np.ndarray, reach: float) -> dict | None:
    """Tool axes along a path whose axis varies, as (tip, tip + reach * axis) segments: the
    written poses `tip`, `written` sampled along the feed moves (at most AXIS_SAMPLES), and the
    CAM's (the CL file's `m`) at every re-oriented pose (at most AXIS_SAMPLES)."""
    cam = np.asarray(m.axis, float)
    if len(cam) == 0 or max(np.ptp(cam, axis=0).max(), np.ptp(written, axis=0).max()) < 1e-6:
        return None
    rows = np.flatnonzero(~np.asarray(m.rapid, bool))
    rows = rows[np.linspace(0, len(rows) - 1, min(len(rows), AXIS_SAMPLES)).astype(int)]
    turned = np.flatnonzero(_angle_deg(written, cam) > REORIENTED_DEG)
    turned = turned[np.linspace(0, len(turned) - 1, min(len(turned), AXIS_SAMPLES)).astype(int)]

    def segments(r: np.ndarray, at: np.ndarray, axis: np.ndarray) -> str:
        return b64(np.stack([at[r], at[r] + reach * axis[r]], axis=1).reshape(-1, 3), "f4")

    return {"segments": segments(rows, tip, written), "count": len(rows),
            "cam": segments(turned, np.asarray(m.tip, float), cam), "cam_count": len(turned)}


def build_view(doc: ResultsDocument, *, toolpath=None, part: Mesh | None = None,
               stock_meshes: Sequence[Mesh] = (), fixtures: Sequence[Mesh] = (),
               cutter=None, config=None, beside: Path | None = None,
               load_part: bool = True, machine: str | None = None,
               deviation: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """The scene (a JSON-able dict) of the checked job `doc`: `toolpath` the program checked
    (default: the CL file `job.path`, read again), `part` its triangles (default: `job.part`
    loaded when `load_part`), `stock_meshes` the stock after each operation in program order
    and `fixtures`, each `(label, vertices (V, 3), triangles (T, 3))` in the part frame (mm);
    `cutter` the cutter the check was given (default: the CL file's); relative paths of the
    document are also looked for in the folder `beside`; `machine` that of a G-code program
    (`read_toolpath`); `deviation` the part's measuring points and their deviation
    (`read_deviation`), which colour the last stock (the machined part against the design)."""
    from checker.check.inputs import job_config

    cfg = job_config(config)
    if toolpath is None:
        toolpath = read_toolpath(doc, beside, machine)
    m = toolpath.motion_arrays(arc_chord_tol=cfg.check.arc_chord_tolerance)
    if part is None and load_part:
        part = part_mesh(doc, beside, config)
    findings = _findings(doc, m)
    ops = np.unique(np.asarray(m.op))
    cutters = _cutters(doc, toolpath, ops, cutter)
    reach = 2.0 * max(float(c.d) for c in cutters.values())
    tip, written = written_path(doc, m)
    boxes = [tip]
    if part is not None:
        boxes.append(np.asarray(part[1], float))
    boxes += [np.asarray(v, float) for _, v, _ in (*stock_meshes, *fixtures)]
    allv = np.concatenate([b.reshape(-1, 3) for b in boxes])
    share = STOCK_TRIANGLES // max(1, len(stock_meshes))
    return {
        "job": {"path": doc.job.path, "part": doc.job.part, "axis_class": doc.job.axis_class,
                "cutter": doc.job.cutter, "status": doc.summary.status, "units": doc.job.units,
                "counts": doc.summary.counts.model_dump(), "tolerance": doc.summary.tolerance},
        "box": [allv.min(axis=0).tolist(), allv.max(axis=0).tolist()],
        "kinds": list(KINDS),
        "part": None if part is None else _mesh(*part, PART_TRIANGLES),
        "path": {"positions": b64(tip, "f4"), "points": len(tip),
                 "kinds": b64(_segment_kinds(m, findings), "u1")},
        "findings": _markers(findings),
        "reoriented": _reoriented(doc, m)[:REORIENTED_ROWS],
        "axes": _axes(m, tip, written, reach),
        "axis_reach": reach,
        "tools": {str(o): {"cutter": c.to_apt(), "pieces": tool_outlines(c)}
                  for o, c in cutters.items()},
        "stock": _stocks(stock_meshes, share, deviation),
        "fixtures": [_mesh(label, v, t, FIXTURE_TRIANGLES) for label, v, t in fixtures],
    }


def _stocks(stock_meshes: Sequence[Mesh], share: int, deviation) -> list[dict]:
    """The stock meshes for the page, the last coloured by the deviation when it is known."""
    out = []
    for k, (label, v, t) in enumerate(stock_meshes):
        mesh = _mesh(label, v, t, share)
        if deviation is not None and k == len(stock_meshes) - 1:
            _deviation_colours(mesh, np.frombuffer(base64.b64decode(mesh["positions"]),
                                                   "<f4").reshape(-1, 3), deviation)
        out.append(mesh)
    return out


def stl_mesh(label: str, path: str | Path) -> Mesh:
    """An STL file (the stock the check wrote, a fixture) as `(label, vertices, triangles)`."""
    from stl import mesh as stl_mesh_

    tri = np.asarray(stl_mesh_.Mesh.from_file(str(path)).vectors, float).reshape(-1, 3)
    return label, tri, np.arange(len(tri)).reshape(-1, 3)
