"""STL meshes (ASCII or binary, via numpy-stl) as the fallback part kind: shared vertices,
triangles and unit triangle normals from the vertex order (right-hand rule), in mm."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError
from checker.part import MeshPart


def read_stl(path: Path, raw: bytes) -> MeshPart:
    """The mesh in `raw` (the bytes of `path`); degenerate (zero-area) triangles are dropped."""
    from stl import mesh as stl_mesh

    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")  # a value beyond float32 overflows: checked below
            m = stl_mesh.Mesh.from_file(str(path), fh=io.BytesIO(raw), calculate_normals=False)
    except Exception as err:  # numpy-stl raises assorted types for malformed files
        raise PathcheckError(f"not a readable STL file: {err}", path=path, code="part") from err
    tri = np.asarray(m.vectors, dtype=np.float64).reshape(-1, 3, 3)
    if tri.size == 0 or not np.isfinite(tri).all():
        raise PathcheckError(
            "STL file holds no triangles or non-finite coordinates (or beyond float32's "
            "3.4e38)", path=path, code="part"
        )
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normals, axis=1)
    keep = length > 0.0
    if not keep.any():
        raise PathcheckError("STL file holds only zero-area triangles", path=path, code="part")
    tri, normals = tri[keep], normals[keep] / length[keep, None]
    vertices, inverse = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
    return MeshPart(
        vertices=vertices, triangles=inverse.reshape(-1, 3).astype(np.int64), normals=normals
    )
