"""3-axis finishing paths made by another CAM library, for tests that check them with pathcheck:
OpenCAMLib's drop-cutter (`ocl.BatchDropCutter`) along a zig-zag raster over a triangle mesh of
the part (e.g. `occ_faces.mesh_shape`, OpenCASCADE's), written as an APT CL file pathcheck reads.

The raster runs along x, its lines `stepover` mm apart in y, over the mesh's x-y box grown by
the cutter's radius; on each line the cutter is dropped every `step` mm (tool axis +z, the tip
at the lowest height where the cutter touches and does not cut a triangle). Where the cutter
is over no triangle the line breaks: the path leaves at a clearance height (`clearance` mm above
the mesh's top) by RAPID, comes back over the next piece's first point by RAPID and feeds down
onto it. Pieces shorter than two points are left out. Part frame, mm; the tool's tip (APT's
GOTO) on the part's surface from above.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import opencamlib as ocl

_LENGTH = 1e4  # mm: OCL's cutter length (drop-cutter treats the cutter as unbounded upwards)


def ocl_cutter(kind: str, diameter: float, corner: float = 0.0):
    """OCL's ball ("ball"), flat ("flat") or bull-nose ("bullnose", corner radius `corner`)."""
    if kind == "ball":
        return ocl.BallCutter(diameter, _LENGTH)
    if kind == "flat":
        return ocl.CylCutter(diameter, _LENGTH)
    if kind == "bullnose":
        return ocl.BullCutter(diameter, corner, _LENGTH)
    raise ValueError(f"cutter kind {kind!r}: expected ball, flat or bullnose")


def stl_surface(vertices: np.ndarray, triangles: np.ndarray) -> ocl.STLSurf:
    """OCL's surface of the triangles `vertices[triangles]`."""
    surf = ocl.STLSurf()
    for a, b, c in np.asarray(vertices, dtype=float)[np.asarray(triangles)]:
        surf.addTriangle(ocl.Triangle(ocl.Point(*a), ocl.Point(*b), ocl.Point(*c)))
    return surf


def drop_raster(vertices: np.ndarray, triangles: np.ndarray, cutter, radius: float,
                stepover: float, step: float) -> list[np.ndarray]:
    """The raster's pieces: a list of (K, 3) tip positions (K >= 2), zig-zag in x (module
    docstring). `cutter` an OCL cutter of radius `radius` mm."""
    v = np.asarray(vertices, dtype=float)
    lo, hi = v.min(axis=0), v.max(axis=0)
    z0 = float(lo[2]) - 10.0 * radius - 10.0  # below the mesh: where an untouched drop stays
    xs = np.arange(lo[0] - radius, hi[0] + radius + 0.5 * step, step)
    ys = np.arange(lo[1] - radius, hi[1] + radius + 0.5 * stepover, stepover)
    X, Y = np.meshgrid(xs, ys)
    X[1::2] = X[1::2, ::-1]  # zig-zag
    bdc = ocl.BatchDropCutter()
    bdc.setSTL(stl_surface(v, triangles))
    bdc.setCutter(cutter)
    bdc.setThreads(1)
    for x, y in zip(X.ravel(), Y.ravel(), strict=True):
        bdc.appendPoint(ocl.CLPoint(float(x), float(y), z0))
    bdc.run()
    Z = np.array([p.z for p in bdc.getCLPoints()]).reshape(X.shape)
    pieces = []
    for x, y, z in zip(X, Y, Z, strict=True):
        touch = z > z0 + 1e-6
        edges = np.flatnonzero(np.diff(np.concatenate([[0], touch.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a >= 2:
                pieces.append(np.column_stack([x[a:b], y[a:b], z[a:b]]))
    return pieces


def write_cl(path: Path, pieces: list[np.ndarray], cutter_apt: str, clearance_z: float,
             partno: str = "OCL DROP-CUTTER FINISHING", feed: float = 1000.0) -> Path:
    """Write the pieces as an APT CL file: UNITS/MM, `cutter_apt` (e.g. "CUTTER/6,3"), and per
    piece RAPID over its first point at `clearance_z`, a feed down onto it, its GOTOs, a RAPID
    up to `clearance_z`. Returns `path`."""
    lines = [f"PARTNO/{partno}", "UNITS/MM", cutter_apt]
    for p in pieces:
        x0, y0, _ = p[0]
        lines += ["RAPID", f"GOTO/{x0:.6f},{y0:.6f},{clearance_z:.6f}", f"FEDRAT/{feed:g},MMPM"]
        lines += [f"GOTO/{x:.6f},{y:.6f},{z:.6f}" for x, y, z in p]
        x1, y1, _ = p[-1]
        lines += ["RAPID", f"GOTO/{x1:.6f},{y1:.6f},{clearance_z:.6f}"]
    lines.append("FINI")
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path


def finishing_job(vertices: np.ndarray, triangles: np.ndarray, apt_path: Path, *,
                  diameter: float = 6.0, lines: int = 20, per_line: int = 80,
                  kind: str = "ball", corner: float = 0.0) -> tuple[Path, int]:
    """A drop-cutter finishing job over the mesh written to `apt_path`: a `kind` cutter of
    `diameter` mm (ball by default: CUTTER/d,d/2), about `lines` raster lines across the
    mesh's y extent and `per_line` drop points along its x extent (so the number of poses does
    not depend on the part's size). Returns (apt_path, number of GOTOs on the part)."""
    v = np.asarray(vertices, dtype=float)
    radius = 0.5 * diameter
    ext = v.max(axis=0) - v.min(axis=0) + 2.0 * radius
    stepover, step = ext[1] / lines, ext[0] / per_line
    pieces = drop_raster(v, triangles, ocl_cutter(kind, diameter, corner), radius, stepover, step)
    if kind == "ball":
        apt = f"CUTTER/{diameter:g},{radius:g}"
    elif kind == "bullnose":
        apt = f"CUTTER/{diameter:g},{corner:g}"
    else:
        apt = f"CUTTER/{diameter:g}"
    clearance = float(v[:, 2].max()) + diameter + 5.0
    write_cl(apt_path, pieces, apt, clearance)
    return Path(apt_path), int(sum(len(p) for p in pieces))


__all__ = ["drop_raster", "finishing_job", "ocl_cutter", "stl_surface", "write_cl"]
