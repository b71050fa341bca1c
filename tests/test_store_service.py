"""The service's recorder (`checker.service.recorder.StoreRecorder`) against the real store:
a checked job becomes a `jobs` row that its `requests` row points to; an error reply is a
request row with the message."""

from __future__ import annotations

from synthetic_results import synthetic_document

from checker.service import recorder
from checker.store import ResultsStore


def test_service_requests_land_in_the_store(tmp_path):
    doc = synthetic_document(4, n=9)
    with ResultsStore(tmp_path / "s.sqlite") as store:
        rec = recorder.StoreRecorder(store)
        rec.record("check", {"ok": True}, 0.25, document=doc, job_path="cam/job7.apt")
        rec.record("allowable", {"ok": False, "error": {"code": "cutter", "message": "bad"}}, 0.01)
        (job,) = store.jobs()
        assert (job.source, job.job_path, job.n_gouge) == (
            "service", "cam/job7.apt", doc.summary.counts.gouge)
        assert store.document(job.id) == doc
        reqs = [(r[1], r[2], r[4], r[5]) for r in store.requests()]
        assert reqs == [("check", 1, None, job.id), ("allowable", 0, "bad", None)]
