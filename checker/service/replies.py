"""The models of the service's replies (protocol version 1, docs/protocol.md): one per op and
the error reply. The service builds replies as dicts (`protocol.ok_reply`, `error_reply`); these
models describe them, for the published JSON Schemas (`checker/service/schemas.py`). Sizes and
coordinates mm in the part frame, angles degrees, times seconds."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

from checker.results import ResultsDocument
from checker.service.protocol import Vec3


class ErrorInfo(BaseModel):
    model_config = ConfigDict(extra="forbid")

    code: str
    message: str
    line: int | None = None


class AllowablePoint(BaseModel):
    """One CC point as in `pathcheck allowable --json`: sizes mm, B degrees."""

    index: int
    cc: Vec3
    normal: Vec3
    allowable: float | None = Field(description="allowable size, mm; null = unbounded")
    limiting_point: Vec3 | None = None
    limiting_surface: int | None = None
    advice: str = Field(description="the real cutter at this CC point: fits, too_large_near, "
                        "too_large_far or inaccessible (`checker.engine.advice`)")
    margin: float | None = Field(None, description="allowable - real size, mm")
    evaluations: int | None = None
    b_best: float | None = None
    allowable_at_best: float | None = None
    b_feasible: list[tuple[float, float]] | None = None


class CutterInfo(BaseModel):
    """The real cutter of an `allowable` reply: size mm, `variable` R or r."""

    model_config = ConfigDict(extra="forbid")

    apt: str
    kind: str
    size: float
    variable: str


class AllowableTiming(BaseModel):
    """Seconds spent; `load_s` and `sample_s` are 0 when the part came from the cache."""

    model_config = ConfigDict(extra="forbid")

    load_s: float
    sample_s: float
    search_s: float
    b_search_s: float | None = None


class CacheStats(BaseModel):
    """A worker's part cache (bytes)."""

    model_config = ConfigDict(extra="forbid")

    entries: int
    bytes: int
    max_bytes: int
    hits: int
    misses: int
    evictions: int


class WorkerCounters(BaseModel):
    """A worker's counters (`pid`, `uptime_s` in seconds when the worker itself answers)."""

    model_config = ConfigDict(extra="forbid")

    requests: int
    errors: int
    pid: int | None = None
    uptime_s: float | None = None


class RunningRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    id: str | int | None
    op: str | None
    running_s: float


class WorkerEntry(BaseModel):
    """One worker in the broker's `stats`: `worker` and `cache` as of its last answer."""

    model_config = ConfigDict(extra="forbid")

    pid: int
    ready: bool
    busy: bool
    request: RunningRequest | None
    worker: WorkerCounters | None = None
    cache: CacheStats | None = None


class BrokerStats(BaseModel):
    model_config = ConfigDict(extra="forbid")

    pid: int
    workers: int
    ready: int
    busy: int
    queued: int
    pids: list[int]
    requests: int
    errors: int
    replaced: int
    refused_keys: int
    uptime_s: float


class _OkReply(BaseModel):
    model_config = ConfigDict(extra="forbid")

    ok: Literal[True]
    v: Literal[1]
    id: str | int | None


class PingReply(_OkReply):
    """`broker` (answered by the broker) or `worker`: the answering process id; `time`: its
    clock, seconds since the epoch."""

    op: Literal["ping"]
    pong: Literal[True]
    time: float
    broker: int | None = None
    worker: int | None = None


class StatsReply(_OkReply):
    """From the broker: `broker` and `workers`; from a worker itself: `worker` and `cache`."""

    op: Literal["stats"]
    protocol: Literal[1]
    broker: BrokerStats | None = None
    workers: list[WorkerEntry] | None = None
    worker: WorkerCounters | None = None
    cache: CacheStats | None = None


class SleepReply(_OkReply):
    op: Literal["sleep"]
    slept: float
    worker: int


class AllowableReply(_OkReply):
    """The `pathcheck allowable --json` document plus the part's cache key and whether it was
    cached."""

    op: Literal["allowable"]
    cutter: CutterInfo
    method: str
    points: list[AllowablePoint]
    timing: AllowableTiming
    part_hash: str
    cached: bool


class CheckReply(_OkReply):
    """The results document; `gcode` the corrected program's text when `post` was true, or
    `refused` (why it was not written) when `on_findings` is refuse and the program as written
    has findings."""

    op: Literal["check"]
    results: ResultsDocument
    gcode: str | None = None
    refused: str | None = None


class ErrorReply(BaseModel):
    """A refused or failed request: `op` and `id` as far as they could be read."""

    model_config = ConfigDict(extra="forbid")

    ok: Literal[False]
    v: Literal[1]
    id: str | int | None
    op: str | None
    error: ErrorInfo


OkReply = PingReply | StatsReply | SleepReply | AllowableReply | CheckReply
REPLY = TypeAdapter(Annotated[OkReply, Field(discriminator="op")] | ErrorReply)
