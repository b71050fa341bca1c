"""pathcheck's verdicts on paths made by another CAM library over every STEP/IGES part of
../shared/realdata, against an independent depth oracle. For each part: an OpenCAMLib
drop-cutter finishing raster with a ball D6 over OpenCASCADE's mesh of the part
(tests/cad_paths.py), checked by pathcheck's real check (`checker.check.check_job`) with a larger
cutter (ball D10, bull-nose D10 r2, flat D8 in turn over the parts: they cut where the D6 only
touched); at each of
pathcheck's checked poses (CL records, the deepest pose of every penetrating move) the depth of
the cutter's body into a fine OpenCASCADE mesh of the part (`BRepMesh`, ORACLE_DEFLECTION mm) by
OpenCAMLib's drop-cutter (tests/ocl_oracle.py). No pose deeper than DEEP by the oracle may be
left unflagged, none at most SHALLOW deep flagged (gouge, interference, holder, crash); the
poses between are within the tolerance band either way (the check's tolerance, 0.02 mm plus
the part's deviation, and the oracle mesh's deflection).

The oracle only has to say on which side of DEEP and of SHALLOW each pose's depth lies: by
ocl_oracle's erosion argument the depth exceeds d iff the cutter eroded by d, its tip raised by
d, still cuts the mesh, i.e. iff its drop-cutter height there is above tip_z + d. So two
`BatchDropCutter` runs per cutter (d = DEEP and d = SHALLOW) classify every pose (axis +z);
the bisection `ocl_depth` measures only the poses the message names. Both drop on the
triangles of the fine mesh under the poses (`under`)."""

from __future__ import annotations

import numpy as np
import pytest
from requires import require_extra

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.cutter import parse_cutter
from checker.verdict import FINDINGS

require_extra("OCP", "cad")
require_extra("opencamlib", "test")
from cad_paths import finishing_job, stl_surface  # noqa: E402
from conftest import REALDATA  # noqa: E402
from occ_faces import box, cad_files, mesh_shape, read_shape  # noqa: E402
from ocl_oracle import drop_heights, eroded_cutter, ocl_depth  # noqa: E402

PARTS = cad_files(REALDATA) if REALDATA.is_dir() else []
MADE_WITH = 6.0                      # mm: the ball the paths are made for
CHECKED_WITH = ("CUTTER/10,5", "CUTTER/10,2", "CUTTER/8")
LINES, PER_LINE = 8, 30              # the raster: lines across y, drop points along x
PATH_DEFLECTION = 0.02               # mm: the mesh the paths are made on
ORACLE_DEFLECTION = 0.004            # mm: the mesh the oracle measures on
DEEP, SHALLOW = 0.05, 0.02
LARGE, WINDOW = 2000.0, 40.0         # mm: a part this large is judged in a window this wide / 2


def _window(shape, half: float):
    """The part of `shape` inside a vertical prism of half-width `half` mm about the centre of
    its x-y box (`BRepAlgoAPI_Common`), and the prism's x-y bounds (x0, y0, x1, y1)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt

    (x0, y0, z0), (x1, y1, z1) = box(shape)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    prism = BRepPrimAPI_MakeBox(gp_Pnt(cx - half, cy - half, z0 - 1.0),
                                gp_Pnt(cx + half, cy + half, z1 + 1.0)).Shape()
    common = BRepAlgoAPI_Common(shape, prism)
    assert common.IsDone()
    return common.Shape(), (cx - half, cy - half, cx + half, cy + half)


@pytest.fixture(scope="module", params=PARTS, ids=lambda p: p.name)
def job(request, realdata, tmp_path_factory):
    """(part path, the D6 job's CL file, the oracle's mesh and its OCL surface, the x-y box
    (x0, y0, x1, y1) of the poses compared). A part larger than LARGE mm (its box diagonal):
    paths and oracle mesh over a window of it (`_window`, 2 WINDOW mm wide), the poses compared
    those whose larger cutter stays inside the window."""
    path = request.param
    shape = read_shape(path)
    lo, hi = box(shape)
    compared = (-np.inf, -np.inf, np.inf, np.inf)
    if np.linalg.norm(hi - lo) > LARGE:
        shape, (x0, y0, x1, y1) = _window(shape, WINDOW)
        reach = 0.5 * max(parse_cutter(c).d for c in CHECKED_WITH) + 1.0
        compared = (x0 + reach, y0 + reach, x1 - reach, y1 - reach)
    coarse = mesh_shape(shape, PATH_DEFLECTION)
    apt, n = finishing_job(coarse.vertices, coarse.triangles,
                           tmp_path_factory.mktemp("cad_oracle") / f"{path.stem}.apt",
                           diameter=MADE_WITH, lines=LINES, per_line=PER_LINE)
    assert n >= 15, f"{path.name}: the raster touches the part at {n} points only"
    fine = mesh_shape(shape, ORACLE_DEFLECTION)
    return path, apt, fine, compared


def under(fine, tips: np.ndarray, reach: float) -> np.ndarray:
    """Indices of the triangles of `fine` whose x-y box comes within `reach` mm of a tip's x-y
    (a superset: box centre within reach + the box's half diagonal of a tip)."""
    from scipy.spatial import cKDTree

    t = fine.vertices[fine.triangles][..., :2]
    lo, hi = t.min(axis=1), t.max(axis=1)
    centre, half = 0.5 * (lo + hi), 0.5 * np.linalg.norm(hi - lo, axis=1)
    d, _ = cKDTree(tips[:, :2]).query(centre)
    return np.flatnonzero(d <= reach + half)


def deeper_than(surf, z_below: float, cutter, tips: np.ndarray, d: float) -> np.ndarray:
    """(N,) bool: the cutter's body (axis +z, unbounded upwards) at `tips` goes deeper than d mm
    into the surface (`surf`, whose lowest point is above z_below): the d-eroded cutter's drop
    height is above the raised tip (module docstring)."""
    drop = drop_heights(surf, eroded_cutter(cutter, d), tips[:, :2], z_below)
    return drop > tips[:, 2] + d


@pytest.mark.slow
def test_larger_cutter_verdicts_agree_with_the_oracle(job):
    """Each part with one of the larger cutters, in turn over the parts (each cutter on a third
    of them: the suite's time)."""
    path, apt, fine, (x0, y0, x1, y1) = job
    cutter_text = CHECKED_WITH[PARTS.index(path) % len(CHECKED_WITH)]
    doc = check_job(apt, path, CheckOptions(cutter=cutter_text))
    poses = [p for p in doc.points if p.depth is not None
             and x0 <= p.tip[0] <= x1 and y0 <= p.tip[1] <= y1]
    tips = np.array([p.tip for p in poses])
    assert np.allclose([p.axis for p in poses], [0.0, 0.0, 1.0])
    cutter = parse_cutter(cutter_text)
    near = under(fine, tips, 0.5 * cutter.d + 1.0)
    surf = stl_surface(fine.vertices, fine.triangles[near])
    z_below = float(fine.vertices[:, 2].min()) - 100.0
    deep = deeper_than(surf, z_below, cutter, tips, DEEP)
    shallow = ~deeper_than(surf, z_below, cutter, tips, SHALLOW)
    flagged = np.array([p.verdict in FINDINGS for p in poses])
    ours = np.array([max(p.depth, 0.0) for p in poses])
    missed = np.flatnonzero(deep & ~flagged)
    false = np.flatnonzero(shallow & flagged)
    assert len(poses) >= 30, f"{path.name}: {len(poses)} poses compared"
    named = np.r_[missed, false]
    depth = (ocl_depth(fine.vertices, fine.triangles[near], cutter, tips[named], [0.0, 0.0, 1.0])
             if len(named) else np.zeros(0))
    short = depth[:len(missed)] - ours[missed]
    worst = int(np.argmax(short)) if len(missed) else None
    assert len(missed) == 0 and len(false) == 0, (
        f"{path.name} {cutter_text}: of {len(poses)} poses, {len(missed)} of {deep.sum()} "
        f"deeper than {DEEP} mm by the oracle are not flagged"
        + (f" (up to {short[worst]:.3f} mm shallower than the oracle's; line "
           f"{poses[missed[worst]].line}: oracle {depth[worst]:.4f} mm, pathcheck "
           f"{ours[missed[worst]]:.4f} mm, {poses[missed[worst]].verdict})"
           if worst is not None else "")
        + f"; {len(false)} at most {SHALLOW} mm deep are flagged"
        + (f" (line {poses[false[0]].line}: oracle {depth[len(missed)]:.4f} mm, pathcheck "
           f"{ours[false[0]]:.4f} mm)" if len(false) else ""))
