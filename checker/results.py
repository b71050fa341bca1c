"""The results document of one checked job (versioned JSON): per point the CC point and normal,
the allowable size, the limiting point and its surface, the verdict, the margin, and for 4-axis
jobs the best B, the feasible B intervals and the B chosen; plus a job summary. The terminal
summary, the service's `check` reply, the store and the report are all views of this document.

Units: mm and degrees in the part frame (inch jobs: see `job.units`, numbers stay in mm here and
`job.units` says how the CL file was written)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

SCHEMA_VERSION = "1.0"

Verdict = Literal["ok", "gouge", "interference", "holder", "inaccessible"]
VERDICTS: tuple[str, ...] = ("ok", "gouge", "interference", "holder", "inaccessible")
Vec3 = tuple[float, float, float]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class PointResult(_Model):
    """One checked pose: a CC point of the path, or an intermediate pose between two of them."""

    index: int = Field(description="position in `points`")
    kind: Literal["cc", "intermediate"]
    move: int = Field(description="index of the motion (GOTO) this pose is at or follows")
    line: int | None = Field(None, description="line of that record in the CL file")
    cc: Vec3 = Field(description="cutter-contact point, part frame, mm")
    normal: Vec3 = Field(description="unit surface normal at cc, out of the material")
    tip: Vec3 | None = Field(None, description="tool tip of the real cutter, part frame, mm")
    axis: Vec3 | None = Field(None, description="tool axis (tip -> spindle), part frame")
    surface: int | None = Field(None, description="id of the surface that carries cc")
    allowable: float | None = Field(
        description="allowable size (R for flat/bull-nose/APT, r for ball/tapered ball), mm; "
        "null = unbounded"
    )
    limiting_point: Vec3 | None = None
    limiting_surface: int | None = None
    verdict: Verdict
    margin: float | None = Field(
        None, description="allowable - real size, mm (negative: the real cutter is too large)"
    )
    depth: float | None = Field(
        None, description="penetration of the real cutter into the part, mm (>0: gouge)"
    )
    b_original: float | None = Field(None, description="B of the CAM's orientation, degrees")
    b_best: float | None = Field(None, description="B that maximises the allowable size, degrees")
    allowable_at_best: float | None = None
    b_feasible: list[tuple[float, float]] | None = Field(
        None, description="intervals [lo, hi] of B, degrees, where the real cutter is safe"
    )
    b_chosen: float | None = Field(None, description="B written to the G-code, degrees")
    verdict_chosen: Verdict | None = Field(
        None, description="verdict of the real cutter at b_chosen (4-axis); `verdict` is at the "
        "CAM's orientation"
    )
    margin_chosen: float | None = Field(None, description="allowable - real size at b_chosen, mm")
    holder_clearance: float | None = Field(
        None, description="minimum stick-out that clears the holder, mm (holder verdicts)"
    )


class JobInfo(_Model):
    path: str
    dialect: str
    units: Literal["mm", "inch"]
    part: str | None = None
    part_hash: str | None = None
    cutter: str = Field(description="the real cutter as an APT CUTTER/ statement")
    cutter_kind: str
    cutter_size: float = Field(description="real size in the allowable variable, mm")
    machine: str | None = None
    axis_class: str


class VerdictCounts(_Model):
    ok: int = 0
    gouge: int = 0
    interference: int = 0
    holder: int = 0
    inaccessible: int = 0


class Finding(_Model):
    """One of the worst findings, for the summary."""

    index: int
    kind: Literal["cc", "intermediate"] = "cc"
    verdict: Verdict
    line: int | None
    cc: Vec3
    depth: float | None
    margin: float | None


class Orientation(_Model):
    """Total rotary motion of the chosen orientations, degrees."""

    dp_total_rotation: float
    greedy_total_rotation: float
    original_total_rotation: float
    infeasible_points: int


class Summary(_Model):
    points: int
    cc_points: int
    intermediate_points: int
    counts: VerdictCounts
    counts_chosen: VerdictCounts | None = Field(
        None, description="4-axis: CC verdicts at the chosen B (the corrected program)"
    )
    worst_margin: float | None
    worst_depth: float | None
    largest_safe_cutter: float | None = Field(
        None, description="smallest allowable size over the path, mm: the largest safe size"
    )
    largest_safe_standard_cutter: str | None = Field(
        None, description="name of the largest tool-library cutter of the family that is safe"
    )
    worst: list[Finding] = Field(default_factory=list)
    time_s: float


class ResultsDocument(_Model):
    schema_version: Literal["1.0"] = SCHEMA_VERSION
    tool: Literal["pathcheck"] = "pathcheck"
    job: JobInfo
    summary: Summary
    orientation: Orientation | None = None
    points: list[PointResult]
    gcode: str | None = Field(None, description="path of the corrected G-code, when written")


def json_schema() -> dict:
    """The published JSON schema of the results document
    (checker/resources/schemas/results.schema.json)."""
    schema = ResultsDocument.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = f"https://pathcheck.invalid/schemas/results-{SCHEMA_VERSION}.json"
    return schema


if __name__ == "__main__":
    import json
    import sys

    json.dump(json_schema(), sys.stdout, indent=2, sort_keys=True)
    sys.stdout.write("\n")
