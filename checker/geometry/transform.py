"""`--part-transform`: a rigid transform applied to a part exported in another frame than its
CL file, x_path = R x_part + t. Written as six numbers "rx,ry,rz,dx,dy,dz" (rotations in
degrees about the X, then Y, then Z axis, then the offset in mm) or as the 12 numbers of a 3x4
matrix "r11,r12,r13,dx,r21,...,dz" (row by row, the layout of APT's CSYS/)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from checker.errors import PathcheckError
from checker.part import MeshPart, Part

_ORTHO_TOL = 1e-4


def rotation_xyz(rx: float, ry: float, rz: float) -> np.ndarray:
    """The rotation by rx about X, then ry about Y, then rz about Z (degrees): Rz Ry Rx."""
    a, b, c = np.radians([rx, ry, rz])
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def parse_transform(text: str) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), t (3,)) from "rx,ry,rz,dx,dy,dz" or a 3x4 matrix (see the module docstring);
    a matrix that is not a rotation is one line saying so."""
    try:
        vals = [float(x) for x in str(text).replace(";", ",").split(",") if x.strip()]
    except ValueError:
        vals = []
    if len(vals) == 6 and np.isfinite(vals).all():
        return rotation_xyz(*vals[:3]), np.asarray(vals[3:], dtype=float)
    if len(vals) == 12 and np.isfinite(vals).all():
        M = np.asarray(vals, dtype=float).reshape(3, 4)
        R = M[:, :3]
        if not (np.allclose(R @ R.T, np.eye(3), atol=_ORTHO_TOL)
                and np.linalg.det(R) > 0.0):
            raise PathcheckError(f"--part-transform: the 3x3 part of '{text}' is not a rotation "
                                 "(orthonormal, determinant +1)", code="usage")
        return R, M[:, 3].copy()
    raise PathcheckError(f"--part-transform: expected 'rx,ry,rz,dx,dy,dz' (degrees, mm) or the "
                         f"12 numbers of a 3x4 matrix, found '{text}'", code="usage")


def transform_part(part: Part, R: np.ndarray, t: np.ndarray) -> Part:
    """The part moved by x -> R x + t (surfaces' poles, a mesh's vertices and normals)."""
    mesh = None
    if part.mesh is not None:
        m = part.mesh
        mesh = MeshPart(m.vertices @ R.T + t, m.triangles, m.normals @ R.T)
    surfaces = [replace(s, ctrlpts=s.ctrlpts @ R.T + t) for s in part.surfaces]
    tag = np.concatenate([R.ravel(), t]).round(12).tobytes().hex()[:16]
    return Part(surfaces=surfaces, source=part.source, content_hash=f"{part.content_hash}-{tag}",
                units=part.units, mesh=mesh)
