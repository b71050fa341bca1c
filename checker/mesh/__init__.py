"""Exact penetration depth of the real tool (body, shank, holder: convex solids of revolution)
into a triangle mesh, with an AABB tree; the allowable cutter size on a mesh; the mesh's chordal
deviation.

```python
from checker.mesh import MeshIndex, tool_pieces, pose_depths, allowable_on_mesh
index = MeshIndex.build(mesh.vertices, mesh.triangles)      # once per mesh
pieces = tool_pieces(cutter, with_holder=True)
res = pose_depths(index, pieces, tips, axes, reach=5.0)     # depth, piece, triangle, point
```
"""

from checker.mesh.allowable import allowable_on_mesh
from checker.mesh.bvh import MeshIndex
from checker.mesh.chord import chordal_deviation
from checker.mesh.depth import PoseDepths, pose_depths
from checker.mesh.tool import ToolPieces, tool_pieces

__all__ = ["MeshIndex", "PoseDepths", "ToolPieces", "allowable_on_mesh", "chordal_deviation",
           "pose_depths", "tool_pieces"]
