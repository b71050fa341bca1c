"""A floor (z = 0) and a wall (x = X_WALL) as a geomdl JSON part, and CL passes of a cutter
along the floor towards the wall: small jobs whose findings have closed forms (a ball of radius
r at x touches the wall once x + r > X_WALL, by x + r - X_WALL)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from engine_parts import geomdl_surface
from geomdl import exchange, multi

X_WALL = 8.0


def _patch(corner, eu, ev):
    c, a, b = (np.asarray(t, float) for t in (corner, eu, ev))
    return geomdl_surface(np.array([[c, c + b], [c + a, c + a + b]]), np.ones((2, 2)), (1, 1),
                          [0, 0, 1, 1], [0, 0, 1, 1])


def write_wall_part(path: Path) -> Path:
    """The floor (normal +z) and the wall (normal -x) written to `path`."""
    floor = _patch([-30, -20, 0], [30 + X_WALL, 0, 0], [0, 40, 0])
    wall = _patch([X_WALL, -20, 0], [0, 40, 0], [0, 0, 30])
    exchange.export_json(multi.SurfaceContainer([floor, wall]), str(path))
    return path


def wall_pass(cutter: str, tool: int, y: float, x_end: float) -> list[str]:
    """CL records: `cutter` (tool `tool`) rapid above x = -10, then along the floor at `y` from
    x = -10 to `x_end` in 0.5 mm steps, and a rapid up to z = 20."""
    xs = np.arange(-10.0, x_end + 0.01, 0.5)
    return [cutter, f"LOADTL/{tool}", "RAPID", f"GOTO/-10.0,{y},20.0", "FEDRAT/500,MMPM",
            *(f"GOTO/{x:.4f},{y},0.0" for x in xs), "RAPID", f"GOTO/{x_end},{y},20.0"]
