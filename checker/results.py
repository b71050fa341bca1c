"""The results document of one checked job (versioned JSON): per checked pose of the written
program the real tool's verdict, depth and where it reaches; at cutting poses the contact, the
allowable size and the margin (advice), and for 4-axis jobs the best B, the feasible B
intervals and the B written; per operation what was done with it; a job summary whose `status`
is the one answer. The terminal summary, the service's `check` reply, the store and the report
are all views of this document.

Units: mm and degrees in the part frame (inch jobs: see `job.units`, numbers stay in mm here and
`job.units` says how the CL file was written)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from checker import verdict

SCHEMA_VERSION = "2.0"

Verdict = Literal["ok", "within_tolerance", "gouge", "interference", "holder", "crash",
                  "inaccessible", "machine"]
VERDICTS: tuple[str, ...] = verdict.VERDICTS
Piece = Literal["body", "shank", "holder"]
PointKind = Literal["cl", "cycle", "move"]
FindingKind = Literal["cl", "cycle", "move", "stock", "fixture", "machine"]
Vec3 = tuple[float, float, float]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class PointResult(_Model):
    """One checked pose of the program that is written: the tool at a CL record (`cl`), at a
    pose a canned cycle adds (`cycle`), or at the deepest pose along the move that ends at a CL
    record (`move`). The verdict is the real tool's (`checker.verdict`); the contact, the
    allowable size, the margin and the B search are advice about cutting poses."""

    index: int = Field(description="position in `points`")
    kind: PointKind
    move: int = Field(description="index of the motion (GOTO) this pose is at or moves to")
    line: int | None = Field(None, description="line of that record in the CL file")
    op: int = Field(0, description="index of the operation")
    rapid: bool = Field(False, description="reached at rapid (a touch is a crash)")
    tip: Vec3 = Field(description="tool tip, part frame, mm")
    axis: Vec3 = Field(description="tool axis (tip -> spindle), part frame")
    t: float | None = Field(None, description="move poses: fraction of the move (0..1)")
    b: float | None = Field(None, description="table angle B written for this pose, degrees")
    verdict: Verdict
    depth: float | None = Field(
        None, description="penetration of the real tool into the part, mm (> 0: penetrates; < 0: "
        "clearance, down to the reach checked)")
    piece: Piece | None = Field(None, description="the part of the tool that reaches deepest")
    tolerance: float | None = Field(
        None, description="penetration allowed at this pose, mm: the operation's tolerance plus "
        "the part's deviation near `point`")
    point: Vec3 | None = Field(None, description="deepest (or nearest) point of the part, mm")
    surface: int | None = Field(None, description="surface that carries `point` (NURBS parts)")
    cc: Vec3 | None = Field(None, description="cutter-contact point (advice), part frame, mm")
    normal: Vec3 | None = Field(None, description="unit surface normal at cc, out of the material")
    cc_surface: int | None = None
    allowable: float | None = Field(
        None, description="allowable size at cc (R for flat/bull-nose/APT, r for ball/tapered "
        "ball), mm; null = unbounded or not computed")
    limiting_point: Vec3 | None = None
    limiting_surface: int | None = None
    margin: float | None = Field(
        None, description="allowable - real size, mm (advice: negative means a smaller cutter "
        "would be needed to touch cc with this axis)")
    b_original: float | None = Field(None, description="B of the CAM's orientation, degrees")
    b_best: float | None = Field(None, description="B that maximises the allowable size, degrees")
    allowable_at_best: float | None = None
    b_feasible: list[tuple[float, float]] | None = Field(
        None, description="intervals [lo, hi] of B, degrees, where the real cutter is safe")
    verdict_cam: Verdict | None = Field(
        None, description="re-oriented operations: the verdict at the CAM's own orientation")
    depth_cam: float | None = None
    holder_clearance: float | None = Field(
        None, description="minimum stick-out that clears the holder, mm (holder verdicts)")
    lead: float | None = Field(
        None, description="re-oriented multi-axis contact poses: the written axis's lead from "
        "the normal towards the feed in the CC frame, degrees (docs/MATH.md §10.1)")
    tilt: float | None = Field(
        None, description="the written axis's tilt from the normal sideways (n x feed), degrees")
    feasible_mask: str | None = Field(
        None, description="the feasible (lead, tilt) grid nodes of this CC point: base64 of "
        "the bits, lead-major, most significant bit first (numpy packbits); the grid is the "
        "operation's `feasible_grid`")
    feasible_crossings: int | None = Field(
        None, description="grid edges on which the boundary of the feasible set was refined")


class JobInfo(_Model):
    path: str
    dialect: str
    units: Literal["mm", "inch"]
    part: str | None = None
    part_hash: str | None = None
    part_transform: list[float] | None = Field(
        None, description="3x4 matrix (row by row) applied to the part, when given")
    cutter: str = Field(description="the first operation's cutter as an APT CUTTER/ statement")
    cutter_kind: str
    cutter_size: float = Field(description="real size in the allowable variable, mm")
    cutters: list[str] = Field(default_factory=list, description="every operation's cutter")
    machine: str | None = None
    axis_class: str
    stated_stock: str | None = Field(
        None, description="the stock the CL file states (`INSERT/Stock Size`) and how `--stock "
        "cl` places it against the part (`checker.stock.stated.place`); None: it states none")


class VerdictCounts(_Model):
    ok: int = 0
    within_tolerance: int = 0
    gouge: int = 0
    interference: int = 0
    holder: int = 0
    crash: int = 0
    inaccessible: int = 0
    machine: int = 0


def findings_in(counts: VerdictCounts) -> int:
    """How many of `counts` are findings (`checker.verdict.FINDINGS`)."""
    return sum(getattr(counts, v) for v in verdict.FINDINGS)


def verdict_counts(verdicts: Iterable[str]) -> VerdictCounts:
    """How many of `verdicts` (strings of VERDICTS) are each verdict."""
    v = np.asarray(list(verdicts), dtype=object)
    return VerdictCounts(**{k: int((v == k).sum()) for k in VerdictCounts.model_fields})


class FeasibleGrid(_Model):
    """The (lead, tilt) grid of a re-oriented multi-axis operation's feasible sets and how its
    axis was chosen (`checker.five_axis.reorient`)."""

    leads: list[float] = Field(description="grid leads, degrees")
    tilts: list[float] = Field(description="grid tilts, degrees")
    boundary_tolerance: float = Field(description="the boundary's accuracy on the grid lines, "
                                      "degrees")
    method: str = Field(description="the planner of the chosen axes")
    points: int = Field(description="contact points planned")
    infeasible_points: int = Field(description="of them, with no feasible axis (the CAM's kept)")
    cam_infeasible_points: int = Field(description="of them, infeasible at the CAM's axis")
    rotary_motion: float | None = Field(
        None, description="total motion of the machine's rotary words along the contact "
        "points, written program, degrees")
    rotary_motion_cam: float | None = Field(None, description="the same at the CAM's axes")


class ContactOrder(_Model):
    """How a multi-axis operation re-oriented by `--strategy contact-order` was planned
    (`checker.five_axis.contact_plan`, docs/MATH.md §11): flat-end and bull-nose poses of the
    highest-order contact, their lead raised where the real tool or the machine rejects them,
    then faired."""

    method: str = Field(description="the planner of the chosen axes")
    points: int = Field(description="contact points planned")
    infeasible_points: int = Field(description="of them, with no accepted pose (the CAM's kept)")
    cam_infeasible_points: int = Field(description="of them, infeasible at the CAM's axis")
    raised_points: int = Field(description="of them, with the lead raised to clear the part or "
                               "reach the machine")
    order: list[int] = Field(description="points by the order of contact reached: "
                             "[0, 1, 2, 3] (3: the third order, seed eq. 7)")
    scallop: float = Field(description="scallop height of the widths, mm")
    width_min: float | None = Field(
        None, description="smallest effective cutting width of the derived poses (order >= "
        "2), mm")
    width_median: float | None = Field(None, description="their median width, mm")
    ball_width_max: float | None = Field(
        None, description="largest width of a ball end mill of the same diameter at the same "
        "points and scallop, mm")
    rotary_motion: float | None = Field(
        None, description="total motion of the machine's rotary words along the contact "
        "points, written program, degrees")
    rotary_motion_cam: float | None = Field(None, description="the same at the CAM's axes")


class OperationResult(_Model):
    """What was done with one operation of the job."""

    index: int
    name: str
    cutter: str
    axis_class: str = Field(description="3-axis, indexed (one tilted axis), 4-axis-Y, multi-axis")
    handling: Literal["as-programmed", "re-oriented", "cam-kept"] = Field(
        description="re-oriented: the B planned here is written; cam-kept: re-orientation did not "
        "remove the findings, the CAM's angles are written")
    b_written: list[float] | None = Field(
        None, description="[min, max] of B written for the operation, degrees")
    tolerance: float = Field(description="penetration allowed, mm (the job's INTOL/THICK or the "
                             "config, plus the arc chord error; the part's deviation near each "
                             "pose adds to it)")
    tolerance_source: str
    counts: VerdictCounts
    counts_cam: VerdictCounts | None = None
    feasible_grid: FeasibleGrid | None = Field(
        None, description="multi-axis operations re-oriented by the allowable planner: the grid "
        "of the points' `feasible_mask`")
    contact_order: ContactOrder | None = Field(
        None, description="multi-axis operations re-oriented by the contact-order planner")


class Finding(_Model):
    """One of the worst findings, for the summary."""

    index: int = Field(description="position in `points` (kind stock or fixture: in "
                       "`stock.findings`)")
    kind: FindingKind = "cl"
    verdict: Verdict
    line: int | None
    op: int = 0
    tip: Vec3
    point: Vec3 | None
    depth: float | None
    b: float | None = None
    margin: float | None = None


class Orientation(_Model):
    """Total rotary motion of the chosen orientations, degrees."""

    dp_total_rotation: float
    greedy_total_rotation: float | None = Field(
        None, description="the greedy smoothing of Jun, Lee and Cha (2002) inside the planned "
        "operations, degrees; only when the config's `four_axis.greedy_baseline` asks for it")
    original_total_rotation: float
    infeasible_points: int


class StockFinding(_Model):
    """A move that hits the stock (material still there when it is made) or a fixture, by the
    one verdict rule (`checker.verdict.decide_stock`, `decide_fixture`)."""

    index: int = Field(description="position in `stock.findings`")
    verdict: Verdict
    against: str = Field(description='"stock", or the fixture\'s name')
    move: int = Field(description="index of the motion (GOTO) the move reaches")
    line: int | None = Field(None, description="line of that record in the CL file")
    op: int = 0
    rapid: bool = False
    piece: Piece | None = None
    depth: float = Field(description="stock: the largest thickness of material the piece "
                         "removes along one vertical ray, mm; fixture: the penetration (the "
                         "deepest point of the fixture inside the tool, its distance to the "
                         "tool's surface, as for the part), mm")
    tolerance: float
    tip: Vec3 = Field(description="tool tip at the pose the move reaches, part frame, mm")
    point: Vec3 | None = Field(None, description="where: stock, the middle of the thickest "
                               "stretch removed; fixture, its deepest point, mm")


class StockOperation(_Model):
    """What one operation does to the stock."""

    op: int
    removed: float = Field(description="material removed, mm^3")
    feed_moves: int
    air_cuts: int = Field(description="feed moves that remove nothing beyond the tolerance")
    air_length: float = Field(description="their length, mm")
    air_time_s: float | None = Field(None, description="their time at the programmed feed, s "
                                     "(None: no feed programmed)")
    depth_max: float = Field(description="largest engaged depth (thickness removed along a "
                             "ray by the cutter's body), mm")
    width_max: float = Field(description="largest engaged width across the direction of "
                             "travel, mm")
    stl: str | None = Field(None, description="the stock after this operation (--stock-out)")


class MoveEngagement(_Model):
    """Per feed move of the program (parallel lists): what the cutter's body removes, for a
    later feed optimisation."""

    move: list[int] = Field(description="index of the motion (GOTO) the move reaches")
    line: list[int]
    volume: list[float] = Field(description="mm^3")
    depth: list[float] = Field(description="engaged depth, mm")
    width: list[float] = Field(description="engaged width, mm")


class MachinedRegion(_Model):
    """A connected area of the machined part (on the part's triangles) whose deviation from
    the design is beyond its threshold by more than the model's bound (docs/MATH.md §15)."""

    index: int
    kind: Literal["left", "overcut"] = Field(description="left: material above the design "
                                             "(advice, rest machining); overcut: material "
                                             "removed below it (a gouge as the machine leaves it)")
    area: float = Field(description="mm^2")
    max: float = Field(description="largest thickness (left) or depth (over-cut), mm")
    mean: float = Field(description="area-weighted mean thickness or depth, mm")
    point: Vec3 = Field(description="where the largest is, part frame, mm")
    vertices: int = Field(description="measuring points in the region")
    op: int | None = Field(None, description="the operation that last cut the region (None: "
                           "none did)")
    allowable: float | None = Field(None, description="left: the largest size (R, or r for a "
                                    "ball) of the job's cutter family that reaches every "
                                    "point of the region gouge-free, mm (None: no point faces "
                                    "the tool axis)")
    tool: str | None = Field(None, description="left: the largest cutter of the tool library "
                             "of that family not above it")


class MachinedOperation(_Model):
    """The deviation after one operation."""

    op: int
    points_cut: int = Field(description="measuring points whose deviation this operation "
                            "lowered by more than the bound")
    left_max: float = Field(description="largest material left above the design at those "
                            "points after it (the scallop its step-over and step-down leave "
                            "beyond `leave`), mm")
    left_mean: float = Field(description="mean of that, mm")
    leave: float = Field(description="stock the operation leaves on purpose (THICK, "
                         "--leave), mm")
    overcut_max: float = Field(description="deepest over-cut anywhere after it, mm")


class MachinedResult(_Model):
    """The machined part (the simulated stock at the end) against the design: the signed
    deviation at the part's measuring points along their outward normals (docs/MATH.md §15)."""

    points: int = Field(description="measuring points (the part's triangles subdivided to "
                        "`spacing`)")
    spacing: float = Field(description="largest edge of the measuring mesh, mm")
    uncovered: int = Field(description="points the stock never covered (left out)")
    bound_along: float = Field(description="error bound along a normal for a vertical one, mm")
    bound_max: float = Field(description="largest bound of any point (horizontal normals: + "
                             "h / sqrt(2)), mm")
    reach: float = Field(description="the search's reach along the normal: deviations are "
                         "capped at +-reach, mm")
    left_max: float = Field(description="largest material left above the design, mm")
    overcut_max: float = Field(description="deepest over-cut, mm (0: none)")
    gouge_points: int = Field(description="points over-cut beyond the tolerance by more than "
                              "the bound (`checker.verdict.decide_machined`); counted here "
                              "only, apart from the check's verdicts")
    left_points: int = Field(description="points left beyond tolerance + leave by more than "
                             "the bound")
    overcut_regions: int = Field(0, description="over-cut regions in all")
    left_regions: int = Field(0, description="left-material regions in all (of at least "
                              "spacing^2)")
    overcut: list[MachinedRegion] = Field(default_factory=list, description="the largest "
                                          "over-cut regions by area (at most 100)")
    left: list[MachinedRegion] = Field(default_factory=list, description="the largest "
                                       "left-material regions by area (at most 100)")
    advice: str | None = Field(None, description='e.g. "rest machining: 3 regions, 41 mm^2, '
                               'up to 0.62 mm thick; largest safe tool BALL-D4"')
    operations: list[MachinedOperation] = Field(default_factory=list)
    deviation_file: str | None = Field(None, description="the part with per-vertex deviation "
                                       "(--deviation-out, PLY or VTK)")
    picture: str | None = Field(None, description="the deviation map (PNG) beside it")
    time_s: float = 0.0


class StockResult(_Model):
    """The program against the stock and the fixtures (docs/MATH.md §14)."""

    stock: str = Field(description="the stock's shape, part frame, mm")
    resolution: float = Field(description="ray spacing of the Z-dexel model, mm")
    error_bound: float = Field(description="bound on the simulated material along each ray, mm")
    volume_initial: float = Field(description="mm^3")
    volume_final: float = Field(description="mm^3")
    fixtures: list[str] = Field(default_factory=list)
    counts: VerdictCounts = Field(description="verdicts of the moves against the stock and the "
                                  "fixtures")
    operations: list[StockOperation] = Field(default_factory=list)
    findings: list[StockFinding] = Field(default_factory=list)
    engagement: MoveEngagement | None = None
    overflow: int = Field(0, description="rays whose cut needed more intervals than the model "
                          "holds (their material kept)")
    final_stl: str | None = None
    machined: MachinedResult | None = Field(None, description="the machined part against the "
                                            "design (with a part)")
    time_s: float = 0.0


class MachineFinding(_Model):
    """Two solids of the machine check closer than the clearance (`checker.verdict.
    decide_machine`): the first contact of a run of consecutive poses in contact."""

    index: int = Field(description="position in `machine.findings`")
    verdict: Verdict
    a: str = Field(description="the solid on the work's side (bed, table, part, stock, fixture)")
    b: str = Field(description="the solid on the tool's side (column, head, spindle, tool)")
    move: int = Field(description="the motion row of the pose the move reaches")
    line: int
    op: int
    t: float = Field(description="where along the move the contact starts (0..1; 1: at the pose)")
    axes: dict[str, float] = Field(description="the program's axis values there (X Y Z: machine "
                                   "position, or the work-frame tip with TCP; rotary words, deg)")
    distance: float = Field(description="the least distance in the run, mm (< 0: penetration)")
    poses: int = Field(description="consecutive poses in contact")


class MachinePair(_Model):
    """The least clearance found between two solids along the program."""

    a: str
    b: str
    least: float = Field(description="mm (< 0: penetration); exact at the checked poses, along "
                         "the moves to the stated precision")
    line: int
    axes: dict[str, float]


class MachineResult(_Model):
    """The machine's own solids against each other, the tool and the work along the motion
    (docs/MATH.md §16)."""

    machine: str
    source: str = Field(description="where the machine's dimensions come from")
    clearance: float = Field(description="mm: closer than this is a `machine` finding")
    solids: list[str] = Field(default_factory=list)
    pairs: int = Field(description="pairs of solids checked")
    counts: VerdictCounts = Field(description="verdicts of the poses and moves against the "
                                  "machine")
    findings: list[MachineFinding] = Field(default_factory=list)
    near_misses: list[MachinePair] = Field(default_factory=list, description="per pair its least "
                                           "clearance, nearest first")
    distances: int = Field(0, description="exact distances computed (coal)")
    time_s: float = 0.0


class Summary(_Model):
    status: Literal["ok", "findings"] = Field(
        description="of the program that is written: 'findings' when any pose is a gouge, "
        "interference, holder hit or crash (exit code 1); the store, the report, the service "
        "and the post hook read this")
    points: int
    cl_points: int = Field(description="poses at CL records")
    move_points: int = Field(description="moves checked along their length (their deepest poses)")
    poses_checked: int = Field(description="poses evaluated, along the moves included")
    counts: VerdictCounts = Field(description="verdicts of the written program: its poses "
                                  "(cl_points) and its moves (move_points)")
    counts_cam: VerdictCounts | None = Field(
        None, description="the same at the CAM's own orientations, when any operation is "
        "re-oriented")
    tolerance: float = Field(description="largest tolerance of the job's operations, mm")
    part_deviation: float = Field(description="typical deviation of the part's triangles from its "
                                  "surfaces, mm (a mesh: its chordal deviation, estimated); the "
                                  "deviation near each pose's deepest point adds to its tolerance")
    worst_margin: float | None
    worst_depth: float | None
    largest_safe_cutter: float | None = Field(
        None, description="smallest allowable size over the cutting poses, mm (advice)")
    largest_safe_standard_cutter: str | None = Field(
        None, description="name of the largest tool-library cutter of the family that is safe")
    worst: list[Finding] = Field(default_factory=list)
    time_s: float


class ResultsDocument(_Model):
    schema_version: Literal["2.0"] = SCHEMA_VERSION
    tool: Literal["pathcheck"] = "pathcheck"
    job: JobInfo
    summary: Summary
    operations: list[OperationResult] = Field(default_factory=list)
    orientation: Orientation | None = None
    points: list[PointResult]
    gcode: str | None = Field(None, description="path of the corrected G-code, when written")
    stock: StockResult | None = Field(None, description="the program against the stock and the "
                                      "fixtures (None: not asked)")
    machine: MachineResult | None = Field(None, description="the machine's solids along the "
                                          "motion (None: not asked)")


def stock_line(stock: StockResult | None, stated: str | None = None) -> str:
    """One line on the stock and the fixtures: what was checked against them and what the
    program does to the stock, or that rapids and holders were not checked against stock (and,
    when the CL file states a stock, `stated`: `JobInfo.stated_stock`, that `--stock cl`
    checks against it)."""
    if stock is None:
        line = ("stock: not checked (no --stock): rapids and holders were checked against the "
                "part only")
        return line if stated is None else (f"{line}; the CL file states a stock, --stock cl "
                                            f"checks against it: {stated}")
    c = stock.counts
    found = f"crash {c.crash}  holder {c.holder}"
    fixtures = f"; fixtures {', '.join(stock.fixtures)}" if stock.fixtures else ""
    if stock.resolution == 0.0:
        return f"against the fixtures{fixtures}: {found}"
    air = sum(o.air_cuts for o in stock.operations)
    air_t = sum(o.air_time_s or 0.0 for o in stock.operations)
    return (f"stock {stock.stock} at {stock.resolution:g} mm{fixtures}: {found}; removed "
            f"{stock.volume_initial - stock.volume_final:.0f} of {stock.volume_initial:.0f} mm^3;"
            f" air cuts {air} ({air_t:.0f} s){machined_text(stock.machined)}")


def machined_text(m: MachinedResult | None) -> str:
    """'; as cut: over-cut 0.79 mm (475 points beyond the tolerance), left up to 0.62 mm;
    rest machining: ...' (docs/MATH.md §15), or '' without a part."""
    if m is None:
        return ""
    text = (f"; as cut: over-cut {m.overcut_max:.3g} mm ({m.gouge_points} points gouged), "
            f"left up to {m.left_max:.3g} mm")
    return text + (f"; {m.advice}" if m.advice else "")


def machine_line(machine: MachineResult) -> str:
    """One line on the machine check: its findings or "no machine collision", and the nearest
    pair."""
    found = (f"{len(machine.findings)} machine collision(s), first at line "
             f"{machine.findings[0].line} ({machine.findings[0].a} / {machine.findings[0].b})"
             if machine.findings else "no machine collision")
    near = machine.near_misses[0] if machine.near_misses else None
    nearest = ("" if near is None else
               f"; nearest {near.a} / {near.b} {near.least:.3f} mm at line {near.line}")
    return (f"machine {machine.machine} ({machine.pairs} pairs, clearance "
            f"{machine.clearance:g} mm): {found}{nearest}; {machine.time_s:.2f} s")


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
