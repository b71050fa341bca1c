"""The part model: plain data. A part is a list of exact (rational) B-spline surfaces in mm in the
part frame, each with an optional trim in its (u, v) domain, or a triangle mesh (STL) fallback.
Evaluation, loading and sampling live in `checker.geometry`."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np


class TrimRegion(Protocol):
    """The kept region of a surface's (u, v) domain (see `checker.geometry.trims.UVTrim`)."""

    loops: list[np.ndarray]

    def contains(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Bool mask (N,): True where (u, v) lies in the kept region."""
        ...


@dataclass(eq=False)
class Surface:
    """One exact tensor-product B-spline surface, rational when `weights` is set.

    `ctrlpts (nu, nv, 3)` Cartesian poles in mm (not weighted), `weights (nu, nv)` or None,
    clamped or unclamped knot vectors `knots_u (nu + degree_u + 1,)`, `knots_v`. The unit normal
    is `du x dv / |du x dv|`, negated when `flip` (so that it points out of the material).
    """

    id: int
    name: str
    kind: str
    degree_u: int
    degree_v: int
    knots_u: np.ndarray
    knots_v: np.ndarray
    ctrlpts: np.ndarray
    weights: np.ndarray | None = None
    trim: TrimRegion | None = None
    flip: bool = False

    def __post_init__(self) -> None:
        self.knots_u = np.ascontiguousarray(self.knots_u, dtype=np.float64)
        self.knots_v = np.ascontiguousarray(self.knots_v, dtype=np.float64)
        self.ctrlpts = np.ascontiguousarray(self.ctrlpts, dtype=np.float64)
        if self.weights is not None:
            self.weights = np.ascontiguousarray(self.weights, dtype=np.float64)
        nu, nv = self.ctrlpts.shape[:2]
        if self.ctrlpts.shape != (nu, nv, 3):
            raise ValueError(f"ctrlpts must be (nu, nv, 3), got {self.ctrlpts.shape}")
        if (
            self.knots_u.size != nu + self.degree_u + 1
            or self.knots_v.size != nv + self.degree_v + 1
        ):
            raise ValueError(
                f"knot vectors of sizes {self.knots_u.size}, {self.knots_v.size} do not fit "
                f"{nu}x{nv} poles of degree {self.degree_u}x{self.degree_v}"
            )
        if self.weights is not None and self.weights.shape != (nu, nv):
            raise ValueError(f"weights must be ({nu}, {nv}), got {self.weights.shape}")

    @property
    def rational(self) -> bool:
        """True when the weights are not all equal (a polynomial surface otherwise)."""
        if self.weights is None:
            return False
        return bool(np.ptp(self.weights) > 1e-14 * float(np.max(np.abs(self.weights))))

    @property
    def domain(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((u0, u1), (v0, v1)): the parameter range where the surface is defined."""
        ku, kv, p, q = self.knots_u, self.knots_v, self.degree_u, self.degree_v
        return (float(ku[p]), float(ku[-p - 1])), (float(kv[q]), float(kv[-q - 1]))

    @property
    def homogeneous(self) -> np.ndarray:
        """(nu, nv, 4) weighted poles (w x, w y, w z, w); w = 1 for polynomial surfaces."""
        w = np.ones(self.ctrlpts.shape[:2]) if self.weights is None else self.weights
        return np.ascontiguousarray(
            np.concatenate([self.ctrlpts * w[..., None], w[..., None]], axis=2)
        )

    def digest(self) -> bytes:
        """sha256 over degrees, knots, poles, weights and flip (for parts built in memory)."""
        h = hashlib.sha256()
        h.update(np.array([self.degree_u, self.degree_v, int(self.flip)], dtype=np.int64).tobytes())
        for arr in (self.knots_u, self.knots_v, self.ctrlpts, self.homogeneous[..., 3]):
            h.update(arr.tobytes())
        if self.trim is not None:
            for loop in self.trim.loops:
                h.update(np.ascontiguousarray(loop, dtype=np.float64).tobytes())
        return h.digest()


@dataclass(eq=False)
class MeshPart:
    """A triangle mesh in mm: `vertices (V, 3)`, `triangles (T, 3)` int vertex indices, unit
    `normals (T, 3)` per triangle (right-hand rule over the vertex order, out of the material)."""

    vertices: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray


@dataclass(eq=False)
class Part:
    """A part: its surfaces (empty for a mesh part) or its `mesh`, in mm in the part frame.

    `content_hash` is the sha256 hex digest of the source file's bytes (or of the surfaces' data
    for parts built in memory); sampling and the service cache by it.
    """

    surfaces: list[Surface]
    source: str = ""
    content_hash: str = ""
    units: str = "mm"
    mesh: MeshPart | None = None
    faces: int = 0
    _bbox: np.ndarray | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.content_hash:
            h = hashlib.sha256()
            for s in self.surfaces:
                h.update(s.digest())
            if self.mesh is not None:
                h.update(np.ascontiguousarray(self.mesh.vertices).tobytes())
                h.update(np.ascontiguousarray(self.mesh.triangles).tobytes())
            self.content_hash = h.hexdigest()
        if not self.faces:
            self.faces = len(self.surfaces) if self.mesh is None else len(self.mesh.triangles)

    def surface(self, surface_id: int) -> Surface:
        """The surface with this id (ids are the positions in `surfaces`)."""
        return self.surfaces[surface_id]

    @property
    def domains(self) -> np.ndarray:
        """(S, 2, 2) the surfaces' parameter boxes: [[u0, u1], [v0, v1]] per surface id."""
        return np.array([s.domain for s in self.surfaces], dtype=np.float64).reshape(-1, 2, 2)

    @property
    def bbox(self) -> np.ndarray:
        """(2, 3) [min, max] corners in mm of the kept (trimmed) part, from an evaluated grid."""
        if self._bbox is None:
            from checker.geometry.part_info import part_bbox

            self._bbox = part_bbox(self)
        return self._bbox
