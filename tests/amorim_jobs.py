"""pathcheck's verdicts on the SolidWorks-CAM jobs of ../shared/realdata/amorim-solidworkscam-apt
(real CL files with the STL of their part) against an independent oracle: OpenCAMLib's
drop-cutter (`ocl_oracle.ocl_depth`, the erosion depth by bisection) run at pathcheck's own
checked poses: the poses at CL records and canned-cycle holes, and the deepest pose of every
move that penetrates. Shared by the test (`test_amorim_oracle.py`) and the benchmark
(`benchmarks/amorim.py`).

The oracle covers flat, ball and bull-nose cutters (not the drills' and chamfer mills' cones);
poses of other cutters are counted apart. A pose is "deep" for the oracle above DEEP mm and
"shallow" at or below SHALLOW mm; pathcheck's verdict must flag every deep pose and no shallow
one (the poses between are within the tolerance band, 0.02 mm plus the mesh's deviation near
the pose, either way)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from ocl_oracle import ocl_depth

from checker.check import check_job
from checker.check.options import CheckOptions
from checker.verdict import FINDINGS

AMORIM = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "amorim-solidworkscam-apt"
JOBS = ("Teste-Metrologia", "RotateThin", "Sacrifice-Board", "Interface-glue")
DEEP, SHALLOW = 0.05, 0.02
_ORACLE_KINDS = ("flat", "ball", "bullnose")


@dataclass
class Comparison:
    """One job: pathcheck's time, poses compared with the oracle and how they split, the
    largest depth difference where both find a penetration, the poses not covered (cones)."""

    job: str
    seconds: float
    oracle_seconds: float
    compared: int
    both: int
    oracle_only: list
    pathcheck_only: list
    max_depth_difference: float
    not_covered: int
    findings: int
    deepest: float


def compare(job: str, **check_options) -> Comparison:
    """Check `job` and run the oracle at its checked poses (see the module docstring)."""
    from checker.geometry import load_part

    apt = AMORIM / f"{job}.apt"
    t0 = time.perf_counter()
    doc = check_job(apt, options=CheckOptions(**check_options))
    seconds = time.perf_counter() - t0
    mesh = load_part(doc.job.part).mesh
    cutters = {op.index: op.cutter for op in doc.operations}
    from checker.cutter import parse_cutter

    parsed = {k: parse_cutter(v) for k, v in cutters.items()}
    pts = [p for p in doc.points if p.depth is not None]
    covered = [p for p in pts if parsed[p.op].kind in _ORACLE_KINDS]
    t1 = time.perf_counter()
    oracle = np.zeros(len(covered))
    for op in sorted({p.op for p in covered}):
        idx = [i for i, p in enumerate(covered) if p.op == op]
        c = parsed[op]
        body = type(c)(c.kind, c.d, c.r, c.R, c.psi, c.theta)  # unbounded, as the oracle's
        oracle[idx] = ocl_depth(mesh.vertices, mesh.triangles, body,
                                np.array([covered[i].tip for i in idx]),
                                np.array([covered[i].axis for i in idx]))
    oracle_seconds = time.perf_counter() - t1
    flagged = np.array([p.verdict in FINDINGS for p in covered], dtype=bool)
    ours = np.array([max(p.depth, 0.0) for p in covered])
    deep, shallow = oracle > DEEP, oracle <= SHALLOW
    both = deep & flagged
    pen = (oracle > 0) & (ours > 0)
    return Comparison(
        job=job, seconds=seconds, oracle_seconds=oracle_seconds, compared=len(covered),
        both=int(both.sum()),
        oracle_only=[(covered[i].line, covered[i].kind, float(oracle[i]), covered[i].verdict,
                      covered[i].tolerance) for i in np.flatnonzero(deep & ~flagged)],
        pathcheck_only=[(covered[i].line, covered[i].kind, float(oracle[i]), float(ours[i]))
                        for i in np.flatnonzero(shallow & flagged)],
        max_depth_difference=float(np.abs(oracle - ours)[pen].max()) if pen.any() else 0.0,
        not_covered=len(pts) - len(covered),
        findings=int(sum(p.verdict in FINDINGS for p in doc.points)),
        deepest=float(max([p.depth for p in pts] + [0.0])))
