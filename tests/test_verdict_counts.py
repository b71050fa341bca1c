"""`checker.results.verdict_counts`: the one count of verdicts that the check's document, each
operation and the stock check all report."""

from __future__ import annotations

import numpy as np

from checker.results import VerdictCounts, verdict_counts
from checker.verdict import VERDICTS


def test_each_verdict_is_counted_once():
    rng = np.random.default_rng(7)
    verdicts = rng.choice(np.array(VERDICTS, dtype=object), size=500)
    c = verdict_counts(verdicts)
    for name in VERDICTS:
        assert getattr(c, name) == int(np.sum(verdicts == name)), name
    assert sum(c.model_dump().values()) == len(verdicts)


def test_no_verdicts_count_zero_and_every_verdict_has_a_count():
    assert verdict_counts([]) == VerdictCounts()
    assert set(VerdictCounts.model_fields) == set(VERDICTS)
