"""The check's stages run one by one on the wall job (a D10 ball end-mill along a floor towards a
wall at X = 8; the allowable radius at a pose clear of the wall is its distance to the wall,
X - x): the job context is a typed record, the advice is its own stage with that closed-form
answer, and the results document is only assembled from the stages' results (it runs with the
allowable-cutter engine and the contact search unavailable, and reads the advice it is given)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest
from wall_jobs import X_WALL, wall_pass, write_wall_part

from checker.apt import read_cl
from checker.check import CheckOptions, check_program
from checker.check.advice import Advice, advise
from checker.check.context import JobContext, job_context
from checker.check.document import build_document
from checker.check.program import plan_program
from checker.check.rotary import rotary_motion
from checker.geometry.tessellate import PartTriangles
from checker.mesh.bvh import MeshIndex
from checker.part import Part
from checker.toolpath import MotionArrays, ToolPath


@pytest.fixture(scope="module")
def stages(tmp_path_factory):
    """The wall job's context, program, advice and rotary motion, stage by stage."""
    d = tmp_path_factory.mktemp("stages")
    write_wall_part(d / "wall.json")
    lines = ["PARTNO/WALL", "UNITS/MM", *wall_pass("CUTTER/10,5", 1, 0.0, 5.0), "FINI"]
    (d / "wall.apt").write_text("\n".join(lines) + "\n")
    job = job_context(read_cl(d / "wall.apt"), None, CheckOptions())
    program = plan_program(job)
    return job, program, advise(job, program), rotary_motion(job, program)


def test_the_context_is_a_typed_record(stages):
    job = stages[0]
    assert isinstance(job, JobContext)
    for name, kind in (("toolpath", ToolPath), ("m", MotionArrays), ("part", Part),
                       ("triangles", PartTriangles), ("index", MeshIndex)):
        assert isinstance(getattr(job, name), kind), name
    assert job.part_path.name == "wall.json" and job.classes == {0: "3-axis"}
    assert job.machine is None and job.planned == frozenset()  # nothing planned or posted
    np.testing.assert_allclose(job.part_box, [[-30, -20, 0], [X_WALL, 20, 30]], atol=1e-9)
    with pytest.raises(dataclasses.FrozenInstanceError):
        job.cfg = None  # type: ignore[misc]


def test_the_advice_stage_gives_the_distance_to_the_wall(stages):
    job, program, advice, _ = stages
    assert isinstance(advice, Advice)
    rows = job.cutting_rows(np.arange(len(job.m)))
    x = job.m.tip[rows, 0]
    clear = x <= X_WALL - 5 - 0.5
    np.testing.assert_allclose(advice.size[rows[clear]], X_WALL - x[clear], atol=1e-4)
    np.testing.assert_allclose(advice.margin[rows[clear]], X_WALL - x[clear] - 5, atol=1e-4)
    assert advice.largest_safe == pytest.approx(np.nanmin(advice.size[rows]), abs=1e-12)
    assert len(advice.pose_verdict) == len(program.written.moves)


def test_the_document_is_only_assembled(stages, monkeypatch):
    job, program, advice, rotary = stages
    expected = check_program(job.toolpath).document

    def unavailable(*_a, **_k):
        raise AssertionError("the document computed instead of assembling")

    for where, name in (("checker.engine", "allowable"), ("checker.geometry.contact", "cl_to_cc"),
                        ("checker.mesh.allowable", "allowable_on_mesh")):
        monkeypatch.setattr(f"{where}.{name}", unavailable)
    doc = build_document(job, program, advice, rotary, time.perf_counter())
    cl = [p for p in doc.points if p.kind == "cl"]
    assert [p.allowable for p in cl] == [p.allowable for p in expected.points if p.kind == "cl"]
    assert doc.summary.counts == expected.summary.counts
    assert doc.summary.largest_safe_cutter == pytest.approx(advice.largest_safe, abs=1e-12)
    # what the advice says is what the document says
    told = dataclasses.replace(advice, largest_safe=1.25, largest_standard="BALL-D2")
    doc = build_document(job, program, told, rotary, time.perf_counter())
    assert doc.summary.largest_safe_cutter == 1.25
    assert doc.summary.largest_safe_standard_cutter == "BALL-D2"
