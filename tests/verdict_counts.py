"""How many of a results document's verdict counts are findings (`checker.verdict.FINDINGS`)."""

from __future__ import annotations

from checker.results import VerdictCounts
from checker.verdict import FINDINGS


def findings_in(counts: VerdictCounts) -> int:
    """Gouges, interferences, holder collisions and crashes counted together."""
    return sum(getattr(counts, v) for v in FINDINGS)
