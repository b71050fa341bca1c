"""Whether the real tool may stand at a CC point with a given axis: the verdict of the check
(`checker.verdict.decide`) at that pose, so that "feasible" here means what the check's verdict
means (docs/MATH.md §8, §10.2). Part frame, mm."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from checker.mesh import MeshIndex, PoseDepths, pose_depths, tool_pieces
from checker.verdict import decide, is_finding


@dataclass(frozen=True)
class PoseJudge:
    """The real tool (`cutter`'s body, shank and holder) against the part's triangles `index`:
    a cutting pose is feasible when its verdict is not a finding, i.e. no piece penetrates by
    more than `tolerance` (mm) plus the deviation of the deepest triangle from the surface it
    stands for (`deviation (T,)` mm, as the check adds it; None: 0). `reach` (mm) bounds the
    clearances computed (0: none, all a verdict needs); `gouge_neighbourhood` (tool radii
    from the tip) names a body hit near the contact a gouge, as the check does (it changes the
    label, never the feasibility);
    `depths` the exact depth (`checker.mesh.pose_depths` or a function with its arguments and
    answer: a test's independent oracle)."""

    index: MeshIndex
    cutter: object
    tolerance: float
    deviation: np.ndarray | None = None
    reach: float = 0.0
    gouge_neighbourhood: float = 2.0
    with_holder: bool = True
    depths: Callable[..., PoseDepths] = pose_depths

    @classmethod
    def for_triangles(cls, triangles, cutter, tolerance: float, **kw) -> PoseJudge:
        """The judge for a part's triangles (`checker.geometry.tessellate.PartTriangles`)."""
        return cls(MeshIndex.build(triangles.vertices, triangles.triangles), cutter,
                   float(tolerance), np.asarray(triangles.deviation, dtype=float), **kw)

    def verdicts(self, cc: np.ndarray, normals: np.ndarray, axes: np.ndarray) -> np.ndarray:
        """(M,) verdicts (`checker.verdict.VERDICTS`) of the cutting poses touching `cc (M, 3)`
        with unit normals `normals (M, 3)` at unit axes `axes (M, 3)`."""
        if len(cc) == 0:
            return np.zeros(0, dtype=object)
        tips = self.cutter.tip_from_contact(cc, normals, axes)
        pieces = tool_pieces(self.cutter, with_holder=self.with_holder)
        got = self.depths(self.index, pieces, tips, axes, reach=self.reach)
        height = np.einsum("ij,ij->i", got.point - tips, axes)
        near = np.nan_to_num(height, nan=np.inf) <= \
            self.gouge_neighbourhood * 0.5 * float(self.cutter.d)
        tol = np.full(len(cc), self.tolerance)
        if self.deviation is not None:
            tol += np.where(got.triangle >= 0, self.deviation[np.maximum(got.triangle, 0)], 0.0)
        return decide(got.depth, got.piece, np.zeros(len(cc), bool), near, tol)

    def __call__(self, cc: np.ndarray, normals: np.ndarray, axes: np.ndarray) -> np.ndarray:
        """(M,) bool: the poses (as in `verdicts`) that are not findings."""
        return ~is_finding(self.verdicts(cc, normals, axes))
