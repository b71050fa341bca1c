"""Test data: synthetic but realistic results documents, for the report's tests and benchmark
before real jobs exist: a raster path of n x n CC points over a wavy mould surface
z = A sin(x/a) cos(y/b) (mm, part frame), ball cutter, allowable radius from the concave
curvature (1/k where the surface is concave, unbounded where convex), 4-axis B values from the
slope along x. Valleys tighter than the cutter are gouged (a depth of 20 % of the excess, over
the 0.02 mm tolerance: a gouge); a wall at the far edge interferes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from checker.errors import PathcheckError
from checker.results import (
    Finding,
    JobInfo,
    Orientation,
    PointResult,
    ResultsDocument,
    Summary,
    VerdictCounts,
)


def _surface(x: np.ndarray, y: np.ndarray, amp: float) -> tuple[np.ndarray, ...]:
    """Height, unit normal (N,3) and the larger concave principal curvature (1/mm) at x, y."""
    a, b = 7.0, 9.0
    z = amp * np.sin(x / a) * np.cos(y / b)
    zx = amp / a * np.cos(x / a) * np.cos(y / b)
    zy = -amp / b * np.sin(x / a) * np.sin(y / b)
    zxx = -amp / a**2 * np.sin(x / a) * np.cos(y / b)
    zyy = -amp / b**2 * np.sin(x / a) * np.cos(y / b)
    zxy = -amp / (a * b) * np.cos(x / a) * np.sin(y / b)
    g = np.sqrt(1 + zx**2 + zy**2)
    normal = np.stack([-zx, -zy, np.ones_like(z)], axis=1) / g[:, None]
    # largest eigenvalue of the Hessian, scaled: > 0 in valleys (concave seen from the tool)
    mean = 0.5 * (zxx + zyy)
    k = (mean + np.sqrt(0.25 * (zxx - zyy) ** 2 + zxy**2)) / g**3
    return z, normal, k


def synthetic_document(
    seed: int = 0, *, n: int = 41, cutter_r: float = 6.0, four_axis: bool = True,
    path: str | None = None,
) -> ResultsDocument:
    """A results document of n*n CC points (raster, mm) for a ball cutter of radius cutter_r."""
    rng = np.random.default_rng(seed)
    amp = 8.0 + 4.0 * rng.random()
    u = np.linspace(0.0, 100.0, n)
    X, Y = np.meshgrid(u, u)
    X[1::2] = X[1::2, ::-1]  # zig-zag raster
    x, y = X.ravel(), Y.ravel()
    z, normal, k = _surface(x, y, amp)
    allowable = np.where(k > 1e-9, 1.0 / np.maximum(k, 1e-9), np.inf)
    wall = x > 96.0  # a wall beside the last rows: interference
    allowable[wall] = np.minimum(allowable[wall], 2.0 + rng.random(wall.sum()))
    allowable = np.minimum(allowable, 80.0)
    margin = allowable - cutter_r
    bad = margin < -1e-3
    depth = np.where(bad, 0.2 * -margin, 0.0)
    verdict = np.where(depth > 0.02, np.where(wall, "interference", "gouge"),
                       np.where(bad, "within_tolerance", "ok"))
    b_best = np.degrees(np.arctan(-normal[:, 0] / normal[:, 2])) if four_axis else None
    if b_best is not None:
        b_chosen = np.convolve(np.pad(b_best, 7, mode="edge"), np.ones(15) / 15, "valid")
    points = [
        PointResult(
            index=i, kind="cl", move=i, line=10 + i, tip=(x[i], y[i], z[i]),
            axis=(0.0, 0.0, 1.0), cc=(x[i], y[i], z[i]), normal=tuple(normal[i]),
            cc_surface=int(x[i] > 50.0), surface=int(x[i] > 50.0), point=(x[i], y[i], z[i]),
            piece="body", allowable=float(allowable[i]),
            limiting_point=(x[i] + 1.0, y[i], z[i]), limiting_surface=int(x[i] > 50.0),
            verdict=verdict[i], margin=float(margin[i]), depth=float(depth[i]),
            b_best=None if b_best is None else float(b_best[i]),
            b=None if b_best is None else float(b_chosen[i]),
            b_feasible=None if b_best is None else [(float(b_best[i] - 20), float(b_best[i] + 20))],
        )
        for i in range(n * n)
    ]
    counts = {v: int(np.sum(verdict == v))
              for v in ("ok", "within_tolerance", "gouge", "interference")}
    worst = np.argsort(-depth)[:5]
    finding = np.isin(verdict, ("gouge", "interference"))
    summary = Summary(
        status="findings" if finding.any() else "ok", points=n * n, cl_points=n * n,
        move_points=n * n - 1, poses_checked=n * n, counts=VerdictCounts(**counts),
        tolerance=0.02, part_deviation=0.0,
        worst_margin=float(margin.min()), worst_depth=float(depth.max()),
        largest_safe_cutter=float(allowable.min()),
        largest_safe_standard_cutter=None,
        worst=[
            Finding(index=int(i), verdict=verdict[i], line=10 + int(i), tip=(x[i], y[i], z[i]),
                    point=(x[i], y[i], z[i]), depth=float(depth[i]), margin=float(margin[i]))
            for i in worst if finding[i]
        ],
        time_s=1.0 + rng.random(),
    )
    path = path or f"jobs/mould_{seed:03d}.apt"
    job = JobInfo(
        path=path, dialect="apt", units="mm", part=path.rsplit(".", 1)[0] + ".json",
        part_hash=f"{seed:016x}",
        cutter=f"CUTTER/{2 * cutter_r:g},{cutter_r:g}", cutter_kind="ball", cutter_size=cutter_r,
        machine="hmc-b" if four_axis else None, axis_class="4-axis-Y" if four_axis else "3-axis",
    )
    orientation = None
    if b_best is not None:
        orientation = Orientation(
            dp_total_rotation=float(np.abs(np.diff(b_chosen)).sum()),
            greedy_total_rotation=float(np.abs(np.diff(b_best)).sum()),
            original_total_rotation=0.0, infeasible_points=0,
        )
    return ResultsDocument(job=job, summary=summary, orientation=orientation, points=points)


def synthetic_job(apt_path: str, **_: object) -> ResultsDocument:
    """A stand-in for `checker.check.check_job` in batch tests and benchmarks: the file holds
    `SEED N` (integers); the document is `synthetic_document(SEED, n=N)` for that path."""
    text = Path(apt_path).read_text(encoding="utf-8").split()
    if len(text) != 2 or not all(t.isdigit() for t in text):
        raise PathcheckError(
            f"expected 'SEED N' (two integers), found {' '.join(text)[:40]!r}", path=apt_path,
            line=1, code="parse",
        )
    seed, n = map(int, text)
    return synthetic_document(seed, n=n, four_axis=seed % 2 == 0, path=str(apt_path))
