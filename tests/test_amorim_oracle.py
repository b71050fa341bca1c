"""The verdicts on real SolidWorks-CAM jobs against OpenCAMLib (tests/amorim_jobs.py): on every
amorim job with an STL, every checked pose the oracle finds deeper than 0.05 mm is flagged
unless it lies within that pose's own tolerance band (0.02 mm + the arcs' chord + the mesh's
chordal deviation near it: the mesh cannot say more), no pose the oracle finds at most 0.02 mm
deep is flagged, and where both find a penetration the depths agree to 1e-4 mm. RotateThin's bore
passes (a D10 whose circles reach 0.75 mm beyond the D22 bore of the STL) are flagged with the
oracle's depth; Telemecanique's part is in another frame than its path, and says so; in the
right frame its facing and drilling are clean, its spot drill cuts what the STL lacks."""

from __future__ import annotations

import numpy as np
import pytest
from amorim_jobs import AMORIM, JOBS, compare

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.errors import PathcheckError
from checker.verdict import FINDINGS


@pytest.fixture(scope="module")
def amorim(realdata):
    return AMORIM


@pytest.mark.parametrize("job", JOBS)
def test_verdicts_agree_with_the_oracle(amorim, job):
    c = compare(job)
    assert c.compared > 1000
    assert c.pathcheck_only == [], f"flagged where the oracle finds <= 0.02 mm: {c.pathcheck_only}"
    # the oracle-only poses are within their own tolerance (the mesh's deviation near them)
    for _line, _kind, depth, verdict, tolerance in c.oracle_only:
        assert verdict == "within_tolerance" and depth <= tolerance + 1e-4
    assert c.max_depth_difference < 1e-4


def test_rotatethin_bore_passes_flagged_with_the_oracle_depth(amorim):
    doc = check_job(amorim / "RotateThin.apt")
    bore = [p for p in doc.points if p.op == 5 and p.verdict == "gouge"]
    assert len(bore) > 300
    # the circles at 6.75 mm from the bore's axis with a D10: 0.75 mm beyond the STL's radius 11,
    # up to 0.79 at the middle of the bore's 36 facets
    deepest = max(p.depth for p in bore)
    assert deepest == pytest.approx(11.75 - 11.0 * 0.996194698, abs=1e-3)
    assert doc.summary.status == "findings"


def test_telemecanique_part_and_path_do_not_line_up(amorim):
    with pytest.raises(PathcheckError, match="part and path do not line up") as err:
        check_job(amorim / "Telemecanique-Tilt-Support1.apt")
    assert "--part-transform" in str(err.value) and "\n" not in str(err.value)


# Telemecanique's STL -> its CL frame: x = 45 - y, y = 35 - z, z = x - 39 (an axis permutation:
# the STL's 10 degree face and the D3.3 holes' axes onto the path's tilted tool axis, the hole
# centres onto the drilling points to 1e-5 mm)
TELEMECANIQUE_FRAME = "0,-1,0,45, 0,0,-1,35, 1,0,0,-39"


def test_telemecanique_in_its_frame_only_the_spot_drill_finds_something(amorim):
    doc = check_job(amorim / "Telemecanique-Tilt-Support1.apt",
                    options=CheckOptions(part_transform=TELEMECANIQUE_FRAME))
    findings = [p for p in doc.points if p.verdict in FINDINGS]
    # the D16 facing (op 1) and the D3.3 drilling (op 3, 10.1 deep in the 9.1 deep holes) clean
    assert {p.op for p in findings} == {1}
    # the D6 spot drill (118 degree point reaching its full diameter 1.80 mm above the tip) fed
    # 2.75 mm deep: a D6 counterbore 0.95 mm deep around each D3.3 hole, which the STL does not
    # have; deepest at the middle of a facet of the 32-sided hole: 3 - 1.65 cos(pi/32)
    assert max(p.depth for p in findings) == pytest.approx(3.0 - 1.65 * np.cos(np.pi / 32),
                                                           abs=1e-3)
    assert all(p.verdict == "gouge" for p in findings)
    holes = np.array([[15.756924, 10.0, -6.156343], [15.756924, 30.0, -6.156343]])
    where = np.array([p.point for p in findings])
    assert (np.linalg.norm(where[:, None] - holes, axis=2).min(axis=1) < 3.5).all()
