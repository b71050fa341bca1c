"""One function per service op: `(request, state) -> result fields`. Thin: each calls library
functions (imported lazily, so a worker that only answers `ping` stays light) and formats their
results as the protocol's reply fields. Bad input raises PathcheckError."""

from __future__ import annotations

import importlib
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from checker.config import Config
from checker.errors import PathcheckError
from checker.service import protocol as p
from checker.service.cache import CachedPart, PartCache, deep_nbytes, file_key, json_key


@dataclass
class WorkerState:
    """What a worker keeps between requests: config, part cache, counters; `broker` holds the
    broker's counters sent with the current request."""

    config: Config
    cache: PartCache
    started: float = field(default_factory=time.time)
    requests: int = 0
    errors: int = 0
    broker: dict = field(default_factory=dict)
    last_document: Any = None
    last_job_path: str = ""


def ping(req: p.PingRequest, state: WorkerState) -> dict:
    return {"pong": True, "worker": os.getpid(), "time": time.time()}


def stats(req: p.StatsRequest, state: WorkerState) -> dict:
    return {
        "protocol": p.PROTOCOL_VERSION,
        "broker": state.broker,
        "worker": {
            "pid": os.getpid(),
            "uptime_s": time.time() - state.started,
            "requests": state.requests,
            "errors": state.errors,
        },
        "cache": state.cache.stats(),
    }


def sleep(req: p.SleepRequest, state: WorkerState) -> dict:
    time.sleep(req.seconds)
    return {"slept": req.seconds, "worker": os.getpid()}


def allowable(req: p.AllowableRequest, state: WorkerState) -> dict:
    """Allowable cutter size at every CC row, as `pathcheck allowable --json` writes it."""
    rows = np.asarray(req.cc, dtype=np.float64).reshape(-1, 6)
    cc, normals = rows[:, :3], _unit_rows(rows[:, 3:], "cc", "normal")
    axis = np.asarray(req.axis, dtype=np.float64)
    axes = np.broadcast_to(axis / np.linalg.norm(axis), cc.shape)
    if isinstance(req.part, p.PartPath):
        _existing(req.part.path)
    parse_cutter = _library("checker.cutter", "parse_cutter", "allowable")
    engine_allowable = _library("checker.engine", "allowable", "allowable")
    cutter = parse_cutter(req.cutter)
    entry, cached, key = cached_part(req.part, state)
    t0 = time.perf_counter()
    result = engine_allowable(entry.test_points, entry.part, cutter, cc, normals, axes,
                              config=state.config)
    extra = {} if req.b_range is None else _best_b(req, entry, cutter, cc, normals, state.config)
    search_s = time.perf_counter() - t0
    points = _points(cc, normals, result, extra)
    return {
        "points": points,
        "part_hash": key,
        "cached": cached,
        "timing": {
            "load_s": 0.0 if cached else entry.load_s,
            "sample_s": 0.0 if cached else entry.sample_s,
            "search_s": search_s,
        },
    }


def check(req: p.CheckRequest, state: WorkerState) -> dict:
    """Check a job with `checker.job.check_job`; `post` also returns the G-code text. Inline
    CL text is named `<apt>` in errors and in the results document."""
    if isinstance(req.part, p.PartPath):
        _existing(req.part.path)
    if req.apt_path is not None:
        _existing(req.apt_path, "apt_path", "a CL file")
    config = _with_options(state.config, req.options)
    check_job = _library("checker.job", "check_job", "check")
    with tempfile.TemporaryDirectory(prefix="pathcheck-service-") as tmp:
        apt_path = Path(req.apt_path) if req.apt_path else Path(tmp) / "job.apt"
        if req.apt is not None:
            apt_path.write_text(req.apt)
        part_path = _part_file(req.part, Path(tmp)) if req.part is not None else None
        gcode_path = Path(tmp) / "job.nc" if req.post else None
        try:
            doc = check_job(apt_path, part_path=part_path, cutter=req.cutter,
                            machine=req.machine, config=config, output=gcode_path)
        except PathcheckError as err:
            if req.apt is None or err.path != str(apt_path):
                raise
            raise PathcheckError(err.message, path=INLINE_APT, line=err.line,
                                 code=err.code) from None
        if req.apt is not None:
            doc.job.path = INLINE_APT
        if gcode_path is not None and not gcode_path.is_file():
            raise PathcheckError("post: true, but this build's check_job wrote no G-code",
                                 code="unavailable")
        state.last_document, state.last_job_path = doc, doc.job.path
        out: dict[str, Any] = {"results": doc.model_dump(mode="json")}
        if gcode_path is not None:
            out["gcode"] = gcode_path.read_text()
        return out


INLINE_APT = "<apt>"
OPTION_SECTIONS = ("geometry", "check", "four_axis", "intermediate", "engine")


def _with_options(config: Config, options: dict[str, Any]) -> Config:
    """`config` with `options` {"SECTION.FIELD": value} applied (sections of OPTION_SECTIONS)
    and validated; errors name the option."""
    if not options:
        return config
    data = config.model_dump()
    for key, value in options.items():
        section, _, name = key.partition(".")
        if section not in OPTION_SECTIONS or name not in data[section]:
            raise PathcheckError(
                f"field 'options.{key}': expected SECTION.FIELD of the config with SECTION one "
                f"of {', '.join(OPTION_SECTIONS)}, found no such setting", code="request")
        data[section][name] = value
    try:
        return Config.model_validate(data)
    except ValidationError as err:
        first = err.errors(include_url=False)[0]
        key = ".".join(str(x) for x in first["loc"])
        raise PathcheckError(f"field 'options.{key}': {first['msg']}", code="request") from None


OPS: dict[type, Callable[[Any, WorkerState], dict]] = {
    p.PingRequest: ping,
    p.StatsRequest: stats,
    p.SleepRequest: sleep,
    p.AllowableRequest: allowable,
    p.CheckRequest: check,
}


# --- parts -----------------------------------------------------------------------------------


def cached_part(spec: p.PartSpec, state: WorkerState) -> tuple[CachedPart, bool, str]:
    """The loaded and sampled part from the cache (keyed by the sha256 of the part's bytes or
    inline JSON, and the sampling settings): `(entry, was_cached, key)`."""
    salt = state.config.geometry.model_dump_json()
    if isinstance(spec, p.PartPath):
        path = _existing(spec.path)
        key = file_key(path, salt)
        load = _library("checker.geometry", "load_part", "allowable")
        entry, cached = state.cache.get(key, lambda: _sampled(lambda: load(path), state.config))
        return entry, cached, key
    key = json_key(spec.geomdl, salt)
    entry, cached = state.cache.get(key, lambda: _sampled(lambda: _inline(spec), state.config))
    return entry, cached, key


def _inline(spec: p.PartInline) -> Any:
    """A Part from inline geomdl exchange JSON (errors name the field `part.geomdl`)."""
    import json

    from checker.part import Part

    read_geomdl = _library("checker.geometry.geomdl_io", "read_geomdl", "allowable")
    surfaces = read_geomdl(Path("part.geomdl"), json.dumps(spec.geomdl))
    if not surfaces:
        raise PathcheckError("field 'part.geomdl': no surface found", code="part")
    return Part(surfaces=surfaces, source="<inline geomdl>")


def _sampled(load: Callable[[], Any], config: Config) -> CachedPart:
    sample_part = _library("checker.geometry.sampling", "sample_part", "allowable")
    t0 = time.perf_counter()
    part = load()
    t1 = time.perf_counter()
    test_points = sample_part(part, config.geometry.sag_tolerance, geometry=config.geometry)
    t2 = time.perf_counter()
    nbytes = deep_nbytes(part) + deep_nbytes(test_points)
    return CachedPart(part, test_points, nbytes, load_s=t1 - t0, sample_s=t2 - t1)


def _part_file(spec: p.PartSpec, folder: Path) -> Path:
    """A path to the part: the given file, or the inline geomdl JSON written into `folder`."""
    if isinstance(spec, p.PartPath):
        return _existing(spec.path)
    import json

    path = folder / "part.json"
    path.write_text(json.dumps(spec.geomdl))
    return path


def _existing(path: str, field_name: str = "part.path", what: str = "a part file") -> Path:
    out = Path(path).expanduser()
    if not out.is_file():
        found = "a directory" if out.is_dir() else "nothing"
        raise PathcheckError(f"field '{field_name}': expected {what}, found {found}",
                             path=out, code="part" if field_name.startswith("part") else "input")
    return out


def _library(module: str, name: str, op: str) -> Any:
    """`module.name`, imported now; a missing library module is an `unavailable` error."""
    try:
        return getattr(importlib.import_module(module), name)
    except (ModuleNotFoundError, AttributeError) as err:
        raise PathcheckError(f"op '{op}' is not available in this build: {err}",
                             code="unavailable") from err


# --- formatting ------------------------------------------------------------------------------


def _unit_rows(v: np.ndarray, field_name: str, what: str) -> np.ndarray:
    """(N, 3) rows scaled to unit length; a zero row is a request error naming its index."""
    norm = np.linalg.norm(v, axis=1)
    bad = np.flatnonzero(norm < 1e-12)
    if bad.size:
        raise PathcheckError(f"field '{field_name}.{bad[0]}': expected a non-zero {what} "
                             f"(columns 4-6), found {v[bad[0]].tolist()}", code="request")
    return v / norm[:, None]


def _best_b(req: p.AllowableRequest, entry: CachedPart, cutter: Any, cc: np.ndarray,
            normals: np.ndarray, config: Config) -> dict[str, Any]:
    """b_best, allowable_at_best and b_feasible per point over `req.b_range` (degrees, mm):
    the engine evaluated at the tool axis of each trial B (DESIGN.md: (-sin B, 0, cos B))."""
    engine_allowable = _library("checker.engine", "allowable", "allowable")
    best_b = _library("checker.four_axis.best_b", "best_b", "allowable with b_range")
    axes_mod = "checker.four_axis.axes"
    axis_for_b = _library(axes_mod, "axis_for_b", "allowable with b_range")
    b_for_axis = _library(axes_mod, "b_for_axis", "allowable with b_range")
    check_b_range = _library(axes_mod, "check_b_range", "allowable with b_range")
    fa = config.four_axis
    lo, hi = req.b_range
    check_b_range(lo, hi, fa.b_min, fa.b_max)

    def sizes(rows: np.ndarray, b_deg: np.ndarray) -> np.ndarray:
        return engine_allowable(entry.test_points, entry.part, cutter, cc[rows], normals[rows],
                                axis_for_b(b_deg), config=config).size

    reference = np.full(len(cc), float(b_for_axis(np.asarray(req.axis, dtype=float))))
    out = best_b(sizes, len(cc), b_min=lo, b_max=hi, coarse_step=fa.b_coarse_step,
                 tolerance=fa.b_tolerance, required=cutter.size + config.check.tolerance,
                 reference=reference)
    return {"b_best": out.b_best, "allowable_at_best": out.allowable_at_best,
            "b_feasible": out.feasible}


def _opt(values: np.ndarray) -> list[float | None]:
    """Floats with nan/inf as None (JSON null: unbounded or not applicable)."""
    arr = np.asarray(values, dtype=float)
    return [float(x) if np.isfinite(x) else None for x in arr]


def _points(cc: np.ndarray, normals: np.ndarray, result: Any, extra: dict[str, Any]) -> list[dict]:
    """The `points` list of the allowable reply, one `protocol.AllowablePoint` dict per row."""
    n = len(cc)
    size = _opt(result.size)
    lp = np.asarray(result.limiting_point, dtype=float).reshape(n, 3)
    surf = np.asarray(result.limiting_surface).reshape(n).tolist()
    has_lp = (np.all(np.isfinite(lp), axis=1) & np.isfinite(result.size)).tolist()
    verdict = [str(v) for v in np.asarray(result.verdict).reshape(n)]
    none = [None] * n
    b_best = _opt(extra["b_best"]) if extra else none
    at_best = _opt(extra["allowable_at_best"]) if extra else none
    feasible = [[[float(a), float(b)] for a, b in iv] for iv in extra["b_feasible"]] \
        if extra else none
    cc_l, n_l, lp_l = cc.tolist(), normals.tolist(), lp.tolist()
    return [
        {"index": i, "cc": cc_l[i], "normal": n_l[i], "allowable": size[i],
         "limiting_point": lp_l[i] if has_lp[i] else None,
         "limiting_surface": surf[i] if has_lp[i] and surf[i] >= 0 else None,
         "verdict": verdict[i], "b_best": b_best[i], "allowable_at_best": at_best[i],
         "b_feasible": feasible[i]}
        for i in range(n)
    ]
