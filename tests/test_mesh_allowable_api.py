"""`engine.allowable` on a mesh part goes through the exact triangle tests: a floor and a wall
as triangles, a ball touching the floor x mm from the wall: the allowable radius is x (the
largest ball that touches the floor there and stays off the wall); facing away: 0."""

from __future__ import annotations

import numpy as np
import pytest

from checker.cutter import parse_cutter
from checker.engine import allowable
from checker.geometry.sampling import sample_part
from checker.part import MeshPart, Part


def _floor_and_wall(x_wall: float) -> Part:
    v = np.array([[-50, -50, 0], [x_wall, -50, 0], [x_wall, 50, 0], [-50, 50, 0],
                  [x_wall, -50, 40], [x_wall, 50, 40]], dtype=float)
    t = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    return Part([], mesh=MeshPart(v, t, n / np.linalg.norm(n, axis=1)[:, None]))


def test_allowable_on_a_mesh_is_the_distance_to_the_wall():
    part = _floor_and_wall(8.0)
    x = np.array([-10.0, 0.0, 3.0, 6.0])
    cc = np.column_stack([x, np.zeros(4), np.zeros(4)])
    up = np.tile([0.0, 0.0, 1.0], (4, 1))
    res = allowable(sample_part(part), part, parse_cutter("CUTTER/10,5"), cc, up, up)
    np.testing.assert_allclose(res.size, 8.0 - x, atol=1e-3)
    # a r = 5 ball 2 mm from the wall does not fit (a mesh has no surfaces to tell a gouge from
    # an interference by)
    assert list(res.advice) == ["fits", "fits", "fits", "too_large_near"]
    down = allowable(sample_part(part), part, parse_cutter("CUTTER/10,5"), cc, up, -up)
    assert (down.size == 0).all() and set(down.advice) == {"inaccessible"}
    assert res.margin[0] == pytest.approx(18.0 - 5.0, abs=1e-3)
