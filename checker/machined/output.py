"""The deviation file: the measuring mesh with its per-vertex signed deviation (mm; + material
left, - over-cut, nan where the stock never covered the part), as binary PLY (a vertex property
`deviation`: MeshLab, ParaView) or binary legacy VTK (POINT_DATA scalars `deviation`:
ParaView), and a
PNG map beside it (a top view coloured by the deviation). Part frame, mm."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from checker.atomic import write_file
from checker.machined.points import SurfaceMesh

SUFFIXES = (".ply", ".vtk")


def _ply(mesh: SurfaceMesh, dev: np.ndarray) -> bytes:
    V, T = mesh.vertices, mesh.triangles
    head = (f"ply\nformat binary_little_endian 1.0\ncomment pathcheck: signed deviation, mm\n"
            f"element vertex {len(V)}\nproperty float x\nproperty float y\nproperty float z\n"
            f"property float nx\nproperty float ny\nproperty float nz\n"
            f"property float deviation\nelement face {len(T)}\n"
            f"property list uchar int vertex_indices\nend_header\n").encode("ascii")
    vert = np.empty(len(V), dtype=[("p", "<f4", 3), ("n", "<f4", 3), ("d", "<f4")])
    vert["p"], vert["n"], vert["d"] = V, mesh.normals, dev
    face = np.empty(len(T), dtype=[("k", "u1"), ("v", "<i4", 3)])
    face["k"], face["v"] = 3, T
    return head + vert.tobytes() + face.tobytes()


def _vtk(mesh: SurfaceMesh, dev: np.ndarray) -> bytes:
    """Legacy VTK, binary (big-endian, as the format wants)."""
    V, T = mesh.vertices, mesh.triangles
    cells = np.column_stack([np.full(len(T), 3), T]).astype(">i4")
    return b"".join([
        (f"# vtk DataFile Version 3.0\npathcheck: signed deviation, mm\nBINARY\n"
         f"DATASET POLYDATA\nPOINTS {len(V)} double\n").encode("ascii"),
        np.ascontiguousarray(V, ">f8").tobytes(),
        f"\nPOLYGONS {len(T)} {4 * len(T)}\n".encode("ascii"), cells.tobytes(),
        (f"\nPOINT_DATA {len(V)}\nSCALARS deviation double 1\nLOOKUP_TABLE default\n"
         ).encode("ascii"),
        np.ascontiguousarray(dev, ">f8").tobytes(), b"\n"])


def _picture(path: Path, mesh: SurfaceMesh, dev: np.ndarray) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.tri import Triangulation

    V, T = mesh.vertices, mesh.triangles
    d = np.where(np.isfinite(dev), dev, 0.0)
    span = max(float(np.abs(d).max(initial=0.0)), 1e-3)
    up = mesh.normals[T].mean(axis=1)[:, 2] > -1e-9                 # seen from above
    keep = T[up] if up.any() else T
    order = np.argsort(V[keep].mean(axis=1)[:, 2])                  # higher faces drawn last
    fig, ax = plt.subplots(figsize=(6.4, 5.2), dpi=100)
    tri = Triangulation(V[:, 0], V[:, 1], keep[order])
    art = ax.tripcolor(tri, d, shading="gouraud", cmap="coolwarm_r",
                       norm=TwoSlopeNorm(0.0, -span, span))
    fig.colorbar(art, ax=ax, label="deviation, mm (+ left, - over-cut)")
    ax.set_aspect("equal")
    ax.set_xlabel("x, mm")
    ax.set_ylabel("y, mm")
    ax.set_title("the machined part against the design (top view)")
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    write_file(path, buf.getvalue(), what="deviation map")


def write_deviation(path: Path, mesh: SurfaceMesh, dev: np.ndarray) -> tuple[Path, Path]:
    """Write `mesh` with `dev (V,)` to `path` (.ply or .vtk) and its map to `path` with .png;
    returns both paths."""
    path = Path(path)
    data = _ply(mesh, dev) if path.suffix.lower() == ".ply" else _vtk(mesh, dev)
    write_file(path, data, what="deviation file")
    picture = path.with_suffix(".png")
    _picture(picture, mesh, dev)
    return path, picture
