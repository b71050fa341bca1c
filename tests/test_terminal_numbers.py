"""The terminal summary's tables print a B or a coordinate that rounds to zero as `0.000`, never
`-0.000` (a 3-axis operation's B computed from its +z axis is -0.0)."""

from __future__ import annotations

from summary_text import summary_text
from synthetic_results import synthetic_document

from checker.commands.terminal import fixed
from checker.results import OperationResult, VerdictCounts, findings_in


def test_fixed_never_prints_a_negative_zero():
    assert [fixed(v, 3) for v in (-0.0, -0.0004, 0.0004, -0.0005001, 1.25, -2.5)] == [
        "0.000", "0.000", "0.000", "-0.001", "1.250", "-2.500"]
    assert fixed(-0.04, 1) == "0.0" and fixed(-0.06, 1) == "-0.1"


def test_three_axis_b_prints_unsigned_in_the_tables():
    doc = synthetic_document(3, n=9, four_axis=False)
    assert doc.summary.worst, "the synthetic job has findings"
    op = OperationResult(index=0, name="floor", cutter="CUTTER/12,6", axis_class="3-axis",
                         handling="re-oriented", b_written=[-0.0, -0.0], tolerance=0.02,
                         tolerance_source="config", counts=doc.summary.counts)
    worst = [f.model_copy(update={"b": -0.0, "tip": (-0.0, 1.0, -0.0001)})
             for f in doc.summary.worst]
    doc = doc.model_copy(update={"operations": [op],
                                 "summary": doc.summary.model_copy(update={"worst": worst})})
    text = summary_text(doc)
    assert "-0.000" not in text and "-0.0 " not in text
    rows = [line for line in text.splitlines() if line.count("│") >= 5]
    assert any("0.000" in r for r in rows), text


def test_the_operations_findings_column_counts_every_finding_verdict():
    """A machine finding is a finding (`checker.verdict.FINDINGS`): the operations table counts
    it with the gouges, interferences, holder hits and crashes."""
    doc = synthetic_document(4, n=9, four_axis=False)
    counts = VerdictCounts(ok=5, gouge=1, crash=2, machine=3, within_tolerance=4)
    assert findings_in(counts) == 6
    op = OperationResult(index=0, name="floor", cutter="CUTTER/12,6", axis_class="3-axis",
                         handling="re-oriented", b_written=None, tolerance=0.02,
                         tolerance_source="config", counts=counts)
    rows = [line.split("│") for line in summary_text(doc.model_copy(
        update={"operations": [op]})).splitlines() if "re-oriented" in line]
    assert len(rows) == 1 and rows[0][-2].strip() == "6", rows
