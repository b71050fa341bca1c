"""The advice never calls a cutter unsafe that the check finds clean at the same poses, on real CAD
parts (../shared/realdata/occt-cad-nurbs: the IGES blade and the STEP turbine of issue 39).

The jobs are 3-axis finishing paths made by another CAM library: OpenCAMLib's drop-cutter with
a D6 ball over OpenCASCADE's own mesh of the part (tests/cad_paths.py, tests/occ_faces.py). At
every pose the check finds clean (no finding, INTOL/0.2), the allowable size the document gives
is at least the cutter's own size and its margin not negative, and a clean job's "largest safe
cutter" is too (checker/check/advice.py, `_clean_is_safe`). Before, the
blade's summary said r = 0.1253 mm (a pose 0.5 micrometre from a B-spline knot line where the
surface creases by 1.35 degrees) and the turbine's r = 0.0874 mm (a pose on an edge between two
faces), both at poses the check found within tolerance."""

from __future__ import annotations

from pathlib import Path

import pytest
from requires import require_extra

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.verdict import FINDINGS

require_extra("OCP", "cad")
require_extra("opencamlib", "test")

from cad_paths import finishing_job  # noqa: E402  (needs opencamlib)
from occ_faces import mesh_shape, read_shape  # noqa: E402  (needs OCP)

PARTS = ("PRO20359-L1.igs", "ec_turbine-A.stp")
BALL_R = 3.0  # mm: the D6 ball the paths are made for
INTOL = 0.2  # mm


def _job(realdata: Path, name: str, folder: Path) -> Path:
    """The D6 ball drop-cutter finishing job over the part `name`, written into `folder` with
    INTOL/0.2: OpenCAMLib drops the ball on OpenCASCADE's triangles, and the ball cuts the exact
    surfaces by up to 0.12 mm at some poses of the blade; within 0.2 mm the blade's job is
    clean and most of the turbine's poses are."""
    path = realdata / "occt-cad-nurbs" / name
    if not path.is_file():
        pytest.skip(f"{path} not found")
    mesh = mesh_shape(read_shape(path), 0.005)
    apt, poses = finishing_job(mesh.vertices, mesh.triangles, folder / f"{path.stem}.apt",
                               lines=20, per_line=80)
    assert poses > 500
    apt.write_text(apt.read_text().replace("UNITS/MM\n", f"UNITS/MM\nINTOL/{INTOL:g}\n", 1))
    return apt


@pytest.mark.slow
@pytest.mark.parametrize("name", PARTS)
def test_advice_never_calls_a_clean_cutter_unsafe(realdata, tmp_path, name):
    part = realdata / "occt-cad-nurbs" / name
    doc = check_job(_job(realdata, name, tmp_path), part,
                    CheckOptions(on_findings="comment"))
    advised = [p for p in doc.points if p.kind == "cl" and p.cc is not None]
    assert len(advised) > 300  # the engine answered at the touching poses (None: unbounded)
    clean = [p for p in advised if p.verdict not in FINDINGS and p.verdict != "inaccessible"]
    assert len(clean) > 0.9 * len(advised)
    low = [(p.line, p.verdict, p.depth, p.allowable) for p in clean
           if p.allowable is not None and p.allowable < BALL_R]
    assert not low, low
    assert all(p.margin >= 0.0 for p in clean if p.margin is not None)
    s = doc.summary
    if s.status == "ok":
        assert s.largest_safe_cutter is None or s.largest_safe_cutter >= BALL_R
