"""The verdicts on real SolidWorks-CAM jobs against OpenCAMLib (tests/amorim_jobs.py): on every
amorim job with an STL, every checked pose the oracle finds deeper than 0.05 mm is flagged
unless it lies within that pose's own tolerance band (0.02 mm + the arcs' chord + the mesh's
chordal deviation near it: the mesh cannot say more), no pose the oracle finds at most 0.02 mm
deep is flagged, and where both find a penetration the depths agree to 1e-4 mm. RotateThin's bore
passes (a D10 whose circles reach 0.75 mm beyond the D22 bore of the STL) are flagged with the
oracle's depth; Telemecanique's part is in another frame than its path, and says so."""

from __future__ import annotations

import pytest
from amorim_jobs import AMORIM, JOBS, compare

from checker.errors import PathcheckError
from checker.job import check_job


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
