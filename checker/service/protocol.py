"""The service protocol, version 1: one JSON object per request and per reply (docs/protocol.md).

Every request has `op` (and optionally `v`, the protocol version, and `id`, echoed in the reply);
every reply has `ok`, `v`, `id` and `op`, and either the op's result fields or `error: {code,
message, line?}`. Coordinates are mm in the part frame, angles in degrees.
"""

from __future__ import annotations

import json
import re
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    TypeAdapter,
    ValidationError,
    model_validator,
)

from checker.errors import PathcheckError

PROTOCOL_VERSION = 1
OPS: tuple[str, ...] = ("ping", "stats", "allowable", "check")

Vec3 = tuple[float, float, float]
CCRow = tuple[float, float, float, float, float, float]
RequestId = Annotated[str, Field(max_length=200)] | int | None


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)


class _Request(_Strict):
    v: Literal[1] = PROTOCOL_VERSION
    id: RequestId = None


class PingRequest(_Request):
    """Liveness and round-trip latency."""

    op: Literal["ping"]


class StatsRequest(_Request):
    """Counters of the broker and of the worker that answers, and its part cache."""

    op: Literal["stats"]


class SleepRequest(_Request):
    """Debug op (only with `[service] debug_ops = true`): hold a worker for `seconds`."""

    op: Literal["sleep"]
    seconds: float = Field(ge=0, le=3600)


class PartPath(_Strict):
    """A part file on the service's machine (geomdl JSON/YAML, STEP, IGES, STL)."""

    path: str = Field(min_length=1, max_length=4096)


class PartInline(_Strict):
    """A part sent inline as geomdl exchange JSON (the object `exchange.export_json` writes)."""

    geomdl: dict[str, Any]


PartSpec = PartPath | PartInline


class AllowableRequest(_Request):
    """Allowable cutter size at CC points: rows `[x, y, z, nx, ny, nz]` (mm, part frame; the
    normal points out of the material); `axis` the tool axis (tip -> spindle) for every point;
    `b_range` `[lo, hi]` degrees adds the best table angle B per point."""

    op: Literal["allowable"]
    part: PartSpec
    cc: list[CCRow] = Field(min_length=1)
    cutter: str = Field(min_length=1, max_length=1000)
    axis: Vec3 = (0.0, 0.0, 1.0)
    b_range: tuple[float, float] | None = None

    @model_validator(mode="after")
    def _check(self) -> AllowableRequest:
        if sum(c * c for c in self.axis) < 1e-24:
            raise ValueError("axis must be a non-zero vector")
        if self.b_range is not None and self.b_range[0] >= self.b_range[1]:
            raise ValueError(f"b_range must be [lo, hi] with lo < hi, found {list(self.b_range)}")
        return self


class CheckRequest(_Request):
    """Check a job: the CL file as text (`apt`) or as a path on the service's machine
    (`apt_path`), with optional part, cutter override (`CUTTER/...`), machine name, config
    options, the B range searched (degrees), `reorient` (plan B for a 3-axis path too,
    re-orient multi-axis operations) and its `strategy`;
    `post: true` also returns the corrected G-code; `on_findings` what posting does when the
    program as written has findings or points without a feasible B (as `pathcheck check
    --on-findings`: `refuse` returns no `gcode` but `refused`, the reason); `stock`, `fixtures`
    and `machine_check` / `machine_clearance` as the command's options."""

    model_config = ConfigDict(json_schema_extra={"oneOf": [  # exactly one source, as _one_source
        {"required": [name], "properties": {name: {"type": "string"}}}
        for name in ("apt", "apt_path")]})

    op: Literal["check"]
    apt: str | None = Field(None, min_length=1)
    apt_path: str | None = Field(None, min_length=1, max_length=4096)
    name: str | None = Field(None, pattern=r"^[A-Za-z0-9_-]{1,64}$",
                             description="job name for inline `apt` (errors, program name)")
    part: PartSpec | None = None
    cutter: str | None = Field(None, min_length=1, max_length=1000)
    machine: str | None = Field(None, min_length=1, max_length=200)
    options: dict[str, float | int | str | bool] = Field(default_factory=dict)
    b_range: tuple[float, float] | None = None
    reorient: bool = False
    strategy: Literal["allowable", "contact-order"] = Field(
        "allowable", description="with `reorient`, the planner of multi-axis operations (as "
        "`pathcheck check --strategy`)")
    part_transform: str | None = Field(
        None, max_length=400, description="'rx,ry,rz,dx,dy,dz' or a 3x4 matrix: the part's "
        "placement in the CL frame (as `pathcheck --part-transform`)")
    post: bool = False
    on_findings: Literal["refuse", "stop", "comment"] = "refuse"
    stock: str | None = Field(
        None, min_length=1, max_length=400, description="the stock (as `pathcheck check "
        "--stock`: box:+M, box:X0,..,Z1, cylinder:..., cl, or a solid's path, read through the "
        "roots)")
    fixtures: list[str] = Field(
        default_factory=list, max_length=32, description="fixtures (as `--fixture`: "
        "FILE[@RX,RY,RZ,DX,DY,DZ], files read through the roots)")
    stock_resolution: float | None = Field(
        None, ge=0.001, le=100.0, description="ray spacing of the stock model, mm")
    machine_check: bool = Field(
        False, description="check the machine's own solids (its [[components]]) against each "
        "other, the tool, the part, the stock and the fixtures along the motion (as `pathcheck "
        "check --machine-check`)")
    machine_clearance: float | None = Field(
        None, ge=0.0, le=10000.0, description="closer than this between the machine's solids, "
        "the tool and the work is a `machine` finding, mm (default 1; implies machine_check)")

    @model_validator(mode="after")
    def _one_source(self) -> CheckRequest:
        if (self.apt is None) == (self.apt_path is None):
            raise ValueError("give exactly one of 'apt' (CL text) and 'apt_path'")
        if self.b_range is not None and self.b_range[0] >= self.b_range[1]:
            raise ValueError(f"b_range must be [lo, hi] with lo < hi, found {list(self.b_range)}")
        return self


Request = PingRequest | StatsRequest | SleepRequest | AllowableRequest | CheckRequest
REQUEST = TypeAdapter(Annotated[Request, Field(discriminator="op")])


# --- replies (their models: checker/service/replies.py) ---------------------------------------


def error_reply(err: PathcheckError, *, request_id: Any = None, op: str | None = None) -> dict:
    """The reply for a failed request: `{ok: false, v, id, op, error: {code, message, line?}}`."""
    return {"ok": False, "v": PROTOCOL_VERSION, "id": request_id, "op": op, "error": err.to_dict()}


def ok_reply(result: dict, *, request_id: Any = None, op: str) -> dict:
    """The reply for a successful request: the op's result fields plus `ok, v, id, op`."""
    return {"ok": True, "v": PROTOCOL_VERSION, "id": request_id, "op": op, **result}


def encode(reply: dict) -> bytes:
    """A reply as compact UTF-8 JSON; non-finite floats become null (JSON has no NaN)."""
    try:
        return json.dumps(reply, separators=(",", ":"), allow_nan=False).encode()
    except ValueError:
        return json.dumps(_finite(reply), separators=(",", ":")).encode()


def _finite(obj: Any) -> Any:
    if isinstance(obj, float):
        return obj if obj == obj and abs(obj) != float("inf") else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


PEEK_BYTES = 64 * 1024  # larger requests: their id is found by a scan, not a JSON parse
_ID = re.compile(rb'"id"\s*:\s*("(?:[^"\\\n]|\\.){0,200}"|-?\d{1,19})\s*[,}]')


def peek(raw: bytes) -> tuple[Any, str | None]:
    """Best effort `(id, op)` of a request that may be invalid, for the error reply: a JSON
    parse of a small request; for a large one, or one that does not parse (too deep, cut
    short), a scan for the last `"id": ...` (clients write `id` last) and no op."""
    if len(raw) <= PEEK_BYTES:
        try:
            data = json.loads(raw)
        except (ValueError, UnicodeDecodeError, RecursionError):
            return _scan_id(raw), None
        if not isinstance(data, dict):
            return None, None
        return _valid_id(data.get("id")), data["op"] if isinstance(data.get("op"), str) else None
    return _scan_id(raw), None


def _scan_id(raw: bytes) -> Any:
    matches = list(_ID.finditer(raw))
    if not matches:
        return None
    try:
        return _valid_id(json.loads(matches[-1].group(1)))
    except ValueError:
        return None


def _valid_id(rid: Any) -> Any:
    return rid if isinstance(rid, int | str) and not isinstance(rid, bool) else None


def parse_request(
    raw: bytes, *, max_bytes: int, max_points: int, debug_ops: bool = False
) -> Request:
    """Validate one request message; raises PathcheckError (code `limit`, `json`, `op`,
    `version` or `request`) naming the field, what was expected and what was found."""
    if len(raw) > max_bytes:
        raise PathcheckError(
            f"request is {len(raw)} bytes, the limit is {max_bytes} bytes", code="limit"
        )
    try:
        request = REQUEST.validate_json(raw)
    except ValidationError as err:
        raise _request_error(err) from None
    if isinstance(request, SleepRequest) and not debug_ops:
        raise _unknown_op("sleep")
    if isinstance(request, AllowableRequest) and len(request.cc) > max_points:
        raise PathcheckError(
            f"field 'cc': {len(request.cc)} points, the limit is {max_points}", code="limit"
        )
    return request


def _unknown_op(op: object) -> PathcheckError:
    return PathcheckError(
        f"unknown op {op!r}; expected one of {', '.join(OPS)}", code="op"
    )


def _request_error(err: ValidationError) -> PathcheckError:
    first = err.errors(include_url=False)[0]
    kind = first["type"]
    if kind == "json_invalid":
        return PathcheckError(f"request is not valid JSON: {first['ctx']['error']}", code="json")
    if kind == "dict_type" and not first["loc"]:
        found = type(first["input"]).__name__
        return PathcheckError(f"request must be a JSON object, found {found}", code="request")
    if kind == "union_tag_not_found":
        return PathcheckError("request has no 'op' field; expected one of " + ", ".join(OPS),
                              code="op")
    if kind == "union_tag_invalid":
        return _unknown_op(first["ctx"]["tag"])
    loc = [str(x) for x in first["loc"][1:] if _is_field(x)]  # [0] is the op tag
    found = _short(first.get("input"))
    if loc == ["v"]:
        return PathcheckError(
            f"protocol version {found} is not supported; this service speaks version "
            f"{PROTOCOL_VERSION}", code="version"
        )
    msg = first["msg"].removeprefix("Value error, ")
    if kind == "missing" and isinstance(first["loc"][-1], int):
        loc, msg = loc[:-1], f"too few items (item {loc[-1]} is missing)"
    return PathcheckError(f"field '{'.'.join(loc) or 'request'}': {msg}, found {found}",
                          code="request")


_TYPE_TAGS = {"int", "str", "float", "bool", "none", "list", "dict", "tuple"}


def _is_field(part: str | int) -> bool:
    """A location element that names a field or an index (not a union member's type tag)."""
    return isinstance(part, int) or (
        re.fullmatch(r"[a-z_][a-z0-9_]*", part) is not None and part not in _TYPE_TAGS
    )


def _short(value: Any, limit: int = 60) -> str:
    text = json.dumps(value) if not isinstance(value, float) else repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
