"""`checker.mesh.pose_depths` against OpenCAMLib's drop-cutter (tests/ocl_oracle.py) on the real
STL meshes of ../shared/realdata/amorim-solidworkscam-apt: flat D10, ball D6 and bull-nose D10 r2
(bodies unbounded upwards, as drop-cutter's), at random poses near each part with a vertical and
a tilted axis. Where either says the tool penetrates the depths agree within 1e-4 mm; where the
oracle says 0, pose_depths says at most 1e-6."""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np
import pytest
from requires import require_extra

from checker.cutter import parse_cutter
from checker.geometry.stl_io import read_stl
from checker.mesh import MeshIndex, pose_depths, tool_pieces

require_extra("opencamlib", "test")
import ocl_oracle  # noqa: E402  (imports opencamlib)

SET = "amorim-solidworkscam-apt"
CUTTERS = ("CUTTER/10", "CUTTER/6,3", "CUTTER/10,2")
AXES = {"vertical": np.array([0.0, 0.0, 1.0]),
        "tilted": np.array([0.35, -0.2, 0.915]) / np.linalg.norm([0.35, -0.2, 0.915])}
NPOSE = 450


def mesh_files() -> list[str]:
    folder = Path(__file__).resolve().parents[2] / "shared" / "realdata" / SET
    return sorted(p.name for p in folder.glob("*.STL")) or ["RotateThin.STL"]


def near_poses(mesh, axis: np.ndarray, n: int, seed: int) -> np.ndarray:
    """Tips near the surface: a random point of it (by area), moved along its normal by -1.5..1.5
    mm and up the axis by 0..4 mm, plus 0.3 mm of noise: some cut the part, some clear it."""
    rng = np.random.default_rng(seed)
    v = mesh.vertices[mesh.triangles]
    area = np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    t = rng.choice(len(v), n, p=area / area.sum())
    u = rng.random((n, 2))
    flip = u.sum(axis=1) > 1
    u[flip] = 1 - u[flip]
    p = v[t, 0] + u[:, :1] * (v[t, 1] - v[t, 0]) + u[:, 1:] * (v[t, 2] - v[t, 0])
    return (p + mesh.normals[t] * rng.uniform(-1.5, 1.5, (n, 1))
            + axis * rng.uniform(0.0, 4.0, (n, 1)) + rng.normal(0.0, 0.3, (n, 3)))


@pytest.fixture(scope="module", params=mesh_files())
def mesh(request, realdata):
    path = realdata / SET / request.param
    if not path.is_file():
        pytest.skip(f"{path} not found")
    m = read_stl(path, path.read_bytes())
    return request.param, m, MeshIndex.build(m.vertices, m.triangles)


@pytest.mark.parametrize("axis_name", list(AXES))
def test_depth_agrees_with_drop_cutter(mesh, axis_name):
    name, m, index = mesh
    axis = AXES[axis_name]
    tips = near_poses(m, axis, NPOSE, zlib.crc32(f"{name}{axis_name}".encode()))
    for text in CUTTERS:
        cutter = parse_cutter(text)
        mine = pose_depths(index, tool_pieces(cutter, with_holder=False), tips, axis,
                           reach=0.0).depth
        oracle = ocl_oracle.ocl_depth(m.vertices, m.triangles, cutter, tips, axis)
        cut = (mine > 0.0) | (oracle > 0.0)
        assert cut.sum() >= NPOSE // 5 and (~cut).sum() >= NPOSE // 20, (name, text, cut.sum())
        err = np.abs(mine - oracle)[cut]
        worst = int(np.flatnonzero(cut)[np.argmax(err)])
        assert err.max() <= 1e-4, (name, text, axis_name, tips[worst], mine[worst],
                                   oracle[worst])
        assert np.all(mine[oracle == 0.0] <= 1e-6), (name, text, axis_name)
