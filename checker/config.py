"""The one validated configuration: the shipped defaults (`checker/resources/defaults.toml`),
overridden by a user file (`--config`) and, for the store path, the environment variable
PATHCHECK_STORE."""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, PositiveInt

from checker.resources import resource
from checker.toml_load import read_toml, validated

DEFAULTS_FILE = resource("defaults.toml")


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class GeometryConfig(_Section):
    sag_tolerance: PositiveFloat = 0.05
    max_samples_per_surface: PositiveInt = 200_000
    min_samples_per_direction: PositiveInt = 8
    max_spacing: PositiveFloat = 1.0
    reader_time_s: PositiveFloat = 20.0
    reader_time_s_per_mb: PositiveFloat = 20.0
    reader_memory_mb: PositiveInt = 2048


class CheckConfig(_Section):
    tolerance: float = Field(0.001, ge=0)
    gouge_neighbourhood: PositiveFloat = 2.0
    arc_chord_tolerance: PositiveFloat = 0.01
    depth_tolerance: float = Field(0.02, ge=0)
    part_deviation: PositiveFloat = 0.005
    reach: PositiveFloat = 1.0
    misaligned_fraction: float = Field(0.5, gt=0, le=1)


class FourAxisConfig(_Section):
    b_min: float = -180.0
    b_max: float = 180.0
    b_coarse_step: PositiveFloat = 6.0
    b_tolerance: PositiveFloat = 0.01
    dp_b_step: PositiveFloat = 0.5
    dp_weight_change: float = Field(1.0, ge=0)
    dp_weight_original: float = Field(0.1, ge=0)
    max_db_per_mm: PositiveFloat = 5.0
    axis_j_tolerance: PositiveFloat = 1e-6
    greedy_baseline: bool = False


class FiveAxisConfig(_Section):
    """Re-orienting multi-axis operations (`checker.five_axis.reorient`); angles in degrees."""

    grid_step_deg: PositiveFloat = 10.0
    lead_limit_deg: float = Field(60.0, gt=0, lt=90)
    tilt_limit_deg: float = Field(60.0, gt=0, lt=90)
    boundary_tolerance_deg: PositiveFloat = 0.25
    singular_cone_deg: float = Field(5.0, ge=0, lt=90)
    max_turn_per_mm_deg: PositiveFloat = 10.0
    preference_weight: float = Field(0.05, ge=0)
    fairing_passes: int = Field(6, ge=0)
    contact_gap: PositiveFloat = 0.05
    scallop_height: PositiveFloat = 0.01


class ServiceConfig(_Section):
    bind: str = "tcp://127.0.0.1:5555"
    workers: PositiveInt = 2
    max_message_bytes: PositiveInt = 16 * 1024 * 1024
    request_timeout_s: PositiveFloat = 600.0
    max_points: PositiveInt = 200_000
    part_cache_bytes: PositiveInt = 512 * 1024 * 1024
    debug_ops: bool = False
    worker_memory_bytes: PositiveInt = 4 * 1024**3
    heartbeat_s: PositiveFloat = 1.0


class StoreConfig(_Section):
    path: str = "~/.local/share/pathcheck/results.sqlite"
    busy_timeout_s: PositiveFloat = 10.0

    def resolved_path(self) -> Path:
        """The store file: PATHCHECK_STORE if set, else `path`, with ~ expanded."""
        return Path(os.environ.get("PATHCHECK_STORE") or self.path).expanduser()


class ReportConfig(_Section):
    standard_diameters: tuple[PositiveFloat, ...] = (3.175, 6.35, 12.7, 25.4, 50.8)
    trend_nights: PositiveInt = 14
    picture_dpi: PositiveInt = 150
    render_workers: PositiveInt = 2


class EngineConfig(_Section):
    max_size: PositiveFloat = 1000.0
    exclusion: PositiveFloat = 1e-3
    ring: PositiveFloat = 0.01
    refine_seeds: PositiveInt = 4
    refine_iterations: PositiveInt = 24
    pso_particles: PositiveInt = 64
    pso_repeat: PositiveInt = 30
    pso_inertia: tuple[float, float] = (0.1, 0.2)
    pso_c2: float = Field(0.5, ge=0)
    pso_c3: float = Field(0.5, ge=0)
    pso_vmax: PositiveFloat = 0.1
    pso_max_iterations: PositiveInt = 2000


class Config(_Section):
    geometry: GeometryConfig = GeometryConfig()
    check: CheckConfig = CheckConfig()
    four_axis: FourAxisConfig = FourAxisConfig()
    five_axis: FiveAxisConfig = FiveAxisConfig()
    service: ServiceConfig = ServiceConfig()
    store: StoreConfig = StoreConfig()
    engine: EngineConfig = EngineConfig()
    report: ReportConfig = ReportConfig()


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        both = isinstance(value, dict) and isinstance(out.get(key), dict)
        out[key] = _merge(out[key], value) if both else value
    return out


def load_config(user_file: str | Path | None = None) -> Config:
    """Defaults merged with an optional user TOML file; invalid fields name the field."""
    data = read_toml(DEFAULTS_FILE, what="config file", code="config")
    source = DEFAULTS_FILE
    if user_file is not None:
        source = Path(user_file)
        data = _merge(data, read_toml(source, what="config file", code="config"))
    return validated(Config, data, subject="config", code="config", path=source)


@lru_cache(maxsize=1)
def default_config() -> Config:
    """The shipped defaults (cached)."""
    return load_config()
