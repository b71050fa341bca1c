"""Fixtures (vise jaws, clamps, the table's top) as solids in the part frame: read from STL or
STEP/IGES, placed by `FILE@RX,RY,RZ,DX,DY,DZ` (rotations about X, Y, Z in degrees, then an offset
in mm, as `--part-transform`), and the real tool against them at every pose and along every
move (`checker.verify.tool_depths`: the same exact depth and the same bound between poses as the
part's check). Part frame, mm."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError
from checker.geometry.transform import parse_transform
from checker.mesh import MeshIndex

_SOLIDS = (".stl", ".step", ".stp", ".igs", ".iges")


@dataclass(frozen=True)
class Fixture:
    """A fixture's `name` (its file's name), its triangles and their AABB tree."""

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    index: MeshIndex

    @property
    def box(self) -> np.ndarray:
        """(2, 3) its bounding box."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])


def parse_fixture(text: str) -> tuple[Path, str | None]:
    """`FILE` or `FILE@RX,RY,RZ,DX,DY,DZ` -> (path, placement text or None)."""
    head, at, tail = str(text).rpartition("@")
    if at and head.lower().endswith(_SOLIDS):
        return Path(head), tail
    return Path(text), None


def fixture_placement(text: str) -> tuple[Path, tuple[np.ndarray, np.ndarray] | None]:
    """The fixture `text` (`parse_fixture`) checked without reading it: (its existing file, its
    placement (R (3, 3), t (3,)) or None); PathcheckError naming what is wrong."""
    path, placement = parse_fixture(text)
    if path.suffix.lower() not in _SOLIDS:
        raise PathcheckError(f"--fixture '{text}': expected an STL, STEP or IGES file, "
                             "optionally @RX,RY,RZ,DX,DY,DZ", code="usage")
    if not path.is_file():
        raise PathcheckError("fixture file not found: expected an existing STL, STEP or IGES "
                             "file", path=path)
    if placement is None:
        return path, None
    try:
        return path, parse_transform(placement)
    except PathcheckError as err:
        raise PathcheckError(f"--fixture '{text}': {err.message.partition(': ')[2]}",
                             code="usage") from None


def load_fixture(text: str, cfg) -> Fixture:
    """The fixture `text` (`fixture_placement`) read (`checker.stock.solid.load_solid`) and
    placed."""
    from checker.stock.solid import load_solid

    path, placed = fixture_placement(text)
    vertices, triangles = load_solid(path, cfg, what="fixture")
    if placed is not None:
        R, t = placed
        vertices = vertices @ R.T + t
    return Fixture(path.name, vertices, triangles, MeshIndex.build(vertices, triangles))
