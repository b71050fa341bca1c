"""One function per service op: `(request, state) -> result fields`. Thin: each calls library
functions (imported in each op, so a worker that only answers `ping` stays light) and formats their
results as the protocol's reply fields. Bad input raises PathcheckError."""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from checker.cc_points import Rows, check_reach, unit_normals
from checker.config import Config
from checker.errors import PathcheckError
from checker.service import protocol as p
from checker.service.part_cache import CachedPart, PartCache, deep_nbytes, file_key, json_key
from checker.service.roots import Roots, redact


@dataclass
class WorkerState:
    """What a worker keeps between requests: config, part cache, counters, and the roots files
    are read from (in a worker process those of `pathcheck serve --root`; in-process callers
    that build a state themselves read anywhere unless they give roots)."""

    config: Config
    cache: PartCache
    started: float = field(default_factory=time.time)
    requests: int = 0
    errors: int = 0
    last_document: Any = None
    last_job_path: str = ""
    roots: Roots = field(default_factory=lambda: Roots([Path.cwd(), Path("/")]))


def ping(req: p.PingRequest, state: WorkerState) -> dict:
    return {"pong": True, "worker": os.getpid(), "time": time.time()}


def stats(req: p.StatsRequest, state: WorkerState) -> dict:
    return {
        "protocol": p.PROTOCOL_VERSION,
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
    """Allowable cutter size at every CC row: the `pathcheck allowable --json` document
    (`cutter`, `method`, `points`, `timing`; `operations.allowable`), plus `part_hash` and
    `cached`."""
    from checker.cutter import parse_cutter
    from checker.operations.allowable import SampledPart, allowable_at_points, check_b_request

    rows = np.asarray(req.cc, dtype=np.float64).reshape(-1, 6)
    named = Rows(field="cc")
    cc, normals = rows[:, :3], unit_normals(rows[:, 3:], named)
    axis = np.asarray(req.axis, dtype=np.float64)
    files = _Files(state.roots)
    part_path = files.part(req.part)
    cutter = parse_cutter(req.cutter)
    check_b_request(req.b_range, state.config)
    try:
        entry, cached, key = cached_part(req.part, state, part_path)
    except PathcheckError as err:
        raise files.shown(err) from None
    check_reach(cc, entry.part.bbox, named)  # as `pathcheck allowable --cc`
    sampled = SampledPart(entry.part, entry.test_points, entry.load_s, entry.sample_s)
    doc = allowable_at_points(sampled, cutter, cc, normals, axis / np.linalg.norm(axis),
                              state.config, b_range=req.b_range, cached=cached)
    return {**doc, "part_hash": key, "cached": cached}


def check(req: p.CheckRequest, state: WorkerState) -> dict:
    """Check a job with `checker.check.check_toolpath`; `post` also returns the G-code text, or
    `refused` (the reason) where `on_findings` refuses the program as written.
    Inline CL text is named `NAME.apt` (`<apt>` without a name) in errors and in the document.
    Every file is read through the roots: the CL file, the part (given or beside the CL file)
    and a machine file (`machine`, else the CL file's `PPRINT/MACHINE`)."""
    from checker.apt import read_cl
    from checker.check import check_toolpath
    from checker.check.options import CheckOptions
    from checker.check.posting import PostRefusedError

    files = _Files(state.roots)
    part_path = files.part(req.part)
    given_apt = files.get(req.apt_path, "apt_path", "a CL file", "input") if req.apt_path else None
    config = _with_options(state.config, req.options)
    with tempfile.TemporaryDirectory(prefix="pathcheck-service-") as tmp:
        label = f"{req.name}.apt" if req.name else INLINE_APT
        apt_path = given_apt or Path(tmp) / f"{req.name or 'job'}.apt"
        if req.apt is not None:
            apt_path.write_text(req.apt)
        if part_path is None and req.part is not None:
            part_path = _part_file(req.part, Path(tmp))
        gcode_path = Path(tmp) / "job.nc" if req.post else None
        refused = None
        try:
            t0 = time.perf_counter()
            toolpath = read_cl(apt_path, require_cutter=req.cutter is None)
            if part_path is None and given_apt is not None:
                part_path = files.beside(given_apt)
            machine = _machine(req.machine, toolpath, files)
            stock = _stock(req, files)
            clearance = _machine_clearance(req, machine, toolpath)
            doc = check_toolpath(toolpath, part_path, CheckOptions(
                cutter=req.cutter, machine=machine, config=config, output=gcode_path,
                b_range=req.b_range, reorient=req.reorient, strategy=req.strategy,
                part_transform=req.part_transform, on_findings=req.on_findings,
                stock=stock, machine_clearance=clearance), started=t0)
        except PostRefusedError as err:
            doc, refused = err.document, f"G-code not written: {err} (on_findings=refuse)"
        except PathcheckError as err:
            if req.apt is None or err.path != str(apt_path):
                raise files.shown(err) from None
            raise PathcheckError(err.message, path=label, line=err.line, code=err.code) from None
        doc.job.path = label if req.apt is not None else req.apt_path
        state.last_document, state.last_job_path = doc, doc.job.path
        out: dict[str, Any] = {"results": doc.model_dump(mode="json")}
        if refused is not None:
            out["refused"] = refused
        elif gcode_path is not None:
            out["gcode"] = gcode_path.read_text()
        return out


def _stock(req: p.CheckRequest, files: _Files):
    """The stock request of a check: the stock's and the fixtures' files read through the
    roots; nothing is written by the service (no stock files). None when neither is asked."""
    if req.stock is None and not req.fixtures:
        return None
    from checker.stock.fixtures import parse_fixture
    from checker.stock.request import StockRequest
    from checker.stock.spec import parse_stock, solid_name

    stock = req.stock
    if stock is not None and solid_name(stock) is not None:  # through the roots, then parsed
        stock = str(files.get(solid_name(stock), "stock", "a stock solid (STL, STEP, IGES)",
                              "input"))
    if stock is not None:
        parse_stock(stock)
    fixtures = []
    for text in req.fixtures:
        path, placement = parse_fixture(text)
        found = str(files.get(str(path), "fixtures", "a fixture (STL, STEP, IGES)", "input"))
        fixtures.append(found if placement is None else f"{found}@{placement}")
    return StockRequest(stock, tuple(fixtures), req.stock_resolution)


def _machine_clearance(req: p.CheckRequest, machine: str | None, toolpath: Any) -> float | None:
    """The clearance of the machine check (mm), None when not asked; checked before the run
    (`checker.collide.section.asked_clearance`): a machine without components is an error
    naming the field (code `request`), a missing collision library one naming the extra to
    install (code `extra`)."""
    if not req.machine_check and req.machine_clearance is None:
        return None
    from checker.collide.section import asked_clearance
    from checker.postproc.post import machine_for_toolpath

    field = "machine_clearance" if req.machine_clearance is not None else "machine_check"
    return asked_clearance(machine_for_toolpath(toolpath, machine), req.machine_clearance,
                           check=f"field '{field}'", clearance_name="field 'machine_clearance'",
                           code="request")


def _machine(name: str | None, toolpath: Any, files: _Files) -> str | None:
    """The machine for `check_toolpath`: a shipped machine by name (its file in the package),
    or a TOML file inside the roots; `name`, else the CL file's `PPRINT/MACHINE NAME`; None:
    the default machine."""
    field_name = "machine"
    if name is None:
        name, field_name = toolpath.machine_name(), "PPRINT/MACHINE"
    if name is None:
        return None
    from checker.postproc.machine import MACHINES_DIR

    shipped = MACHINES_DIR / f"{name}.toml"
    if "/" not in name and shipped.is_file():
        return str(shipped)
    return str(files.get(name, field_name, "a shipped machine name or a machine TOML file",
                         "machine"))


INLINE_APT = "<apt>"
OPTION_SECTIONS = ("geometry", "check", "four_axis", "engine")


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


def cached_part(spec: p.PartSpec, state: WorkerState,
                path: Path | None = None) -> tuple[CachedPart, bool, str]:
    """The loaded and sampled part from the cache (keyed by the sha256 of the part's bytes or
    inline JSON, and the sampling settings): `(entry, was_cached, key)`. `path` is the part
    file already checked against the roots (for a `{"path"}` part)."""
    salt = state.config.geometry.model_dump_json()
    if isinstance(spec, p.PartPath):
        path = path or _Files(state.roots).get(spec.path, "part.path", "a part file", "part")
        key = file_key(path, salt)
        from checker.geometry import load_part

        entry, cached = state.cache.get(
            key, lambda: _sampled(lambda: load_part(path, geometry=state.config.geometry),
                                  state.config))
        return entry, cached, key
    key = json_key(spec.geomdl, salt)
    entry, cached = state.cache.get(key, lambda: _sampled(lambda: _inline(spec), state.config))
    return entry, cached, key


def _inline(spec: p.PartInline) -> Any:
    """A Part from inline geomdl exchange JSON (errors name the field `part.geomdl`)."""
    import json

    from checker.geometry.geomdl_io import read_geomdl
    from checker.part import Part

    surfaces = read_geomdl(Path("part.geomdl"), json.dumps(spec.geomdl))
    if not surfaces:
        raise PathcheckError("field 'part.geomdl': no surface found", code="part")
    return Part(surfaces=surfaces, source="<inline geomdl>")


def _sampled(load: Callable[[], Any], config: Config) -> CachedPart:
    from checker.operations.allowable import sampled_part

    sampled = sampled_part(load, config)
    nbytes = deep_nbytes(sampled.part) + deep_nbytes(sampled.test_points)
    return CachedPart(sampled.part, sampled.test_points, nbytes, load_s=sampled.load_s,
                      sample_s=sampled.sample_s)


def _part_file(spec: p.PartInline, folder: Path) -> Path:
    """The inline geomdl JSON written into `folder`."""
    import json

    path = folder / "part.json"
    path.write_text(json.dumps(spec.geomdl))
    return path


class _Files:
    """The files one request names, each checked against the roots; `shown` turns an error
    about one of them back to the name the client gave, with the file's contents hidden."""

    def __init__(self, roots: Roots) -> None:
        self.roots = roots
        self.given: dict[str, str] = {}  # resolved path -> the client's name for it

    def get(self, name: str, field_name: str, what: str, code: str) -> Path:
        path = self.roots.file(name, field_name, what, code)
        self.given[str(path)] = name
        return path

    def part(self, spec: p.PartSpec | None) -> Path | None:
        if not isinstance(spec, p.PartPath):
            return None
        return self.get(spec.path, "part.path", "a part file", "part")

    def beside(self, apt: Path) -> Path | None:
        """The part beside the CL file (same stem), checked against the roots like a given
        one; None when there is none (the job then reports it)."""
        from checker.geometry import find_part_beside

        found = find_part_beside(apt)
        return None if found is None else self.get(str(found), "part", "a part file", "part")

    def shown(self, err: PathcheckError) -> PathcheckError:
        name = self.given.get(err.path or "")
        if name is None:
            return err
        err = redact(err, name)
        return PathcheckError(err.message, path=name, line=err.line, code=err.code)
