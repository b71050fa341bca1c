"""The published results schema is current, and documents validate against it (jsonschema)."""

from __future__ import annotations

import json

import jsonschema
import pytest

from checker.resources import resource
from checker.results import (
    JobInfo,
    PointResult,
    ResultsDocument,
    Summary,
    VerdictCounts,
    json_schema,
)


def test_published_schema_is_up_to_date():
    published = json.loads(resource("schemas", "results.schema.json").read_text())
    assert published == json.loads(json.dumps(json_schema())), (
        "regenerate with: .venv/bin/python -m checker.results "
        "> checker/resources/schemas/results.schema.json")


def _document(verdict: str = "gouge") -> ResultsDocument:
    point = PointResult(index=0, kind="cl", move=0, line=12, tip=(1.0, 2.0, 6.0),
                        axis=(0.0, 0.0, 1.0), verdict=verdict, depth=0.05, piece="body",
                        point=(1.0, 2.0, 3.0), cc=(1.0, 2.0, 3.0), normal=(0.0, 0.0, 1.0),
                        allowable=2.5, margin=-0.5, b_best=12.5, b_feasible=[(-10.0, 30.0)],
                        b=0.0)
    return ResultsDocument(
        job=JobInfo(path="job.apt", dialect="apt", units="mm", cutter="CUTTER/6,3",
                    cutter_kind="ball", cutter_size=3.0, axis_class="4-axis-Y"),
        summary=Summary(status="findings", points=1, cl_points=1, move_points=0,
                        poses_checked=1, counts=VerdictCounts(gouge=1), tolerance=0.02,
                        part_deviation=0.0, worst_margin=-0.5, worst_depth=0.05, time_s=0.1),
        points=[point],
    )


def test_documents_validate_against_the_published_schema():
    schema = json.loads(resource("schemas", "results.schema.json").read_text())
    doc = json.loads(_document().model_dump_json())
    jsonschema.validate(doc, schema)
    doc["points"][0]["verdict"] = "melted"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(doc, schema)
