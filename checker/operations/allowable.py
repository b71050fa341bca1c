"""The allowable cutter at given CC points, the `pathcheck allowable` document: the flow that
`pathcheck allowable` and the service's `allowable` op both run. Part frame, mm; B in degrees."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from checker.b_axis import check_b_range
from checker.config import Config
from checker.engine import AllowableResult, allowable
from checker.engine.allowable_output import allowable_document
from checker.four_axis.b_plan import best_b_points
from checker.geometry.sampling import TestPoints, sample_part
from checker.part import Part
from checker.progress import step

CHUNK_ROWS = 20_000  # CC rows per search: the engine's working arrays grow with a search's rows


@dataclass
class SampledPart:
    """A part, its test points and the seconds spent loading and sampling them."""

    part: Part
    test_points: TestPoints
    load_s: float
    sample_s: float


def sampled_part(load: Callable[[], Part], config: Config) -> SampledPart:
    """The part `load()` returns and its test points at the config's sag tolerance, timed."""
    t0 = time.perf_counter()
    with step("load the part"):
        part = load()
    t1 = time.perf_counter()
    with step("sample the part"):
        test_points = sample_part(part, config.geometry.sag_tolerance, geometry=config.geometry)
    return SampledPart(part, test_points, t1 - t0, time.perf_counter() - t1)


def check_b_request(b_range: tuple[float, float] | None, config: Config) -> None:
    """A B range asked for must be ordered and inside the config's `[four_axis] b_min, b_max`."""
    if b_range is not None:
        check_b_range(*b_range, config.four_axis.b_min, config.four_axis.b_max)


def allowable_at_points(sampled: SampledPart, cutter, cc: np.ndarray, normals: np.ndarray,
                        axis: np.ndarray, config: Config, *, method: str = "exact",
                        seed: int | None = None, b_range: tuple[float, float] | None = None,
                        cached: bool = False) -> dict[str, Any]:
    """The largest cutter of `cutter`'s family at each CC point `cc (N, 3)` with unit normals
    `normals (N, 3)` and unit tool axis `axis (3,)`: the document `{cutter, method, points,
    timing}` (`allowable_output.allowable_document`); with `b_range` (degrees, checked against
    the config) every point also gets `b_best`, `allowable_at_best` and `b_feasible`. `cached`:
    the part was loaded before (its load and sample times count 0)."""
    check_b_request(b_range, config)
    t0 = time.perf_counter()
    with step("allowable cutter search"):
        res = _in_chunks(sampled, cutter, cc, normals, axis, config, method, seed)
    timing = {"load_s": 0.0 if cached else sampled.load_s,
              "sample_s": 0.0 if cached else sampled.sample_s,
              "search_s": time.perf_counter() - t0}
    doc = allowable_document(res, cc, normals, cutter, method, timing)
    if b_range is not None:
        t1 = time.perf_counter()
        best_b_points(doc, sampled.test_points, sampled.part, cutter, cc, normals, b_range,
                      config)
        doc["timing"]["b_search_s"] = round(time.perf_counter() - t1, 6)
    return doc


def _in_chunks(sampled: SampledPart, cutter, cc: np.ndarray, normals: np.ndarray,
               axis: np.ndarray, config: Config, method: str, seed: int | None
               ) -> AllowableResult:
    """`engine.allowable` over CHUNK_ROWS rows at a time (each row's search is its own), so
    that the memory of a search of many rows is its result's, not its working arrays'. The
    "pso" baseline draws from one random stream for all rows: it runs whole."""
    step_rows = CHUNK_ROWS if method == "exact" else max(len(cc), 1)
    parts = [allowable(sampled.test_points, sampled.part, cutter, cc[k:k + step_rows],
                       normals[k:k + step_rows], axis, method=method, seed=seed, config=config)
             for k in range(0, len(cc), step_rows) or [0]]
    if len(parts) == 1:
        return parts[0]
    return AllowableResult(*(np.concatenate([getattr(p, f.name) for p in parts])
                             for f in fields(AllowableResult)))
