"""The mould sample in a vise, for the tests of the stock's entry points (CLI, check-gcode,
service, batch): the mould job's motion read straight from its CL file (a regular expression,
no code of pathcheck's), and a vise of two jaw boxes written as STL beside the stock's Y faces,
clear of the path, or with one jaw moved into it. Part frame, mm."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from stl import mesh as stl_mesh

REPO = Path(__file__).resolve().parents[1]
MOULD = REPO / "samples" / "mould"
RADIUS = 5.0          # the job's CUTTER/10,5: a ball 10 mm across
STOCK_Y = 57.0        # `box:+2` about the part (Y -55..55): the stock's Y faces
JAW_TOP = 5.0         # the jaws stand 3 mm above the stock's top (Z 2), from Z -25
INTO = 3.0            # mm the moved jaw stands inside the tool's reach
_GOTO = re.compile(r"^GOTO/\s*([-+.\d]+)\s*,\s*([-+.\d]+)\s*,\s*([-+.\d]+)")
_FACES = np.array([(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
                   (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)])


def gotos(apt: Path) -> tuple[np.ndarray, np.ndarray]:
    """(lines (N,), tips (N, 3)) of the GOTO records of a CL file: 1-based line numbers."""
    lines, tips = [], []
    for number, text in enumerate(Path(apt).read_text().splitlines(), start=1):
        found = _GOTO.match(text)
        if found:
            lines.append(number)
            tips.append([float(v) for v in found.groups()])
    return np.array(lines), np.array(tips)


def write_boxes(path: Path, boxes) -> Path:
    """Axis-aligned boxes [(lo (3,), hi (3,)), ...] as one binary STL, outward normals."""
    tris = []
    for lo, hi in boxes:
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        corners = np.array([[hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1],
                             hi[2] if i & 4 else lo[2]] for i in range(8)])
        tris.append(corners[_FACES])
    vectors = np.concatenate(tris)
    m = stl_mesh.Mesh(np.zeros(len(vectors), dtype=stl_mesh.Mesh.dtype))
    m.vectors[:] = vectors
    m.save(str(path))
    return path


def inner_face(apt: Path = MOULD / "mould.apt") -> float:
    """Y of the moved jaw's inner face: `INTO` mm inside the tool's reach in +Y (the path's
    largest Y plus the ball's radius)."""
    return float(gotos(apt)[1][:, 1].max()) + RADIUS - INTO


def vise(path: Path, *, moved: bool = False) -> Path:
    """Two jaws 10 mm thick along the stock's X (-82..82), Z -25..JAW_TOP, against its faces
    Y = -+STOCK_Y; with `moved` the +Y jaw's inner face at `inner_face()`."""
    _, tips = gotos(MOULD / "mould.apt")
    assert tips[:, 1].max() + RADIUS < STOCK_Y - 10.0  # the jaws at the faces are clear
    y = inner_face() if moved else STOCK_Y
    return write_boxes(path, [((-82.0, -STOCK_Y - 10.0, -25.0), (82.0, -STOCK_Y, JAW_TOP)),
                              ((-82.0, y, -25.0), (82.0, y + 10.0, JAW_TOP))])


def into_jaw(lines: np.ndarray, tips: np.ndarray, tolerance: float) -> tuple[set, set]:
    """The moved jaw's crashes as the geometry says, per GOTO line: (the lines whose pose
    reaches into the jaw by more than `tolerance`: they must be crashes; the lines whose move,
    from the previous pose to this one, stays clear of it: they must not be). The ball's
    centre is below the jaw's top at every pose that reaches that far, so the penetration at
    a pose is its Y + RADIUS - the inner face (the cylinder above the ball)."""
    face = inner_face()
    reach = tips[:, 1] + RADIUS - face
    prev = np.concatenate([[reach[0]], reach[:-1]])
    low = tips[:, 2] + RADIUS < JAW_TOP
    must = set(lines[(reach > tolerance) & low].tolist())
    never = set(lines[np.maximum(reach, prev) <= 0.0].tolist())
    return must, never
