"""Part geometry: `load_part(path) -> Part` for geomdl JSON/YAML, STEP, IGES and STL files, and
`find_part_beside(job_path)`. Evaluation, trims, sampling and part info are in the submodules."""

from __future__ import annotations

import hashlib
from pathlib import Path

from checker.config import GeometryConfig, default_config
from checker.errors import PathcheckError, read_input
from checker.geometry.part_limits import check_mesh, check_surface
from checker.part import Part
from checker.sandbox import Limits

BESIDE_SUFFIXES = (".step", ".stp", ".igs", ".iges", ".json", ".stl")
_READERS = {
    ".json": "geomdl",
    ".yaml": "geomdl",
    ".yml": "geomdl",
    ".step": "step",
    ".stp": "step",
    ".igs": "iges",
    ".iges": "iges",
    ".stl": "stl",
}
_CACHE: dict[tuple[str, str], Part] = {}
_CACHE_MAX = 8  # parts kept in memory (oldest dropped first)

__all__ = ["BESIDE_SUFFIXES", "find_part_beside", "load_part", "reader_limits"]


def find_part_beside(job_path: str | Path) -> Path | None:
    """The part file beside a job with the same stem, whatever the case of stem and suffix
    (SolidWorks writes `JOB.STL`, others `Job.Step`): the first of BESIDE_SUFFIXES found, or
    None. Two files of that suffix differing only in case (`job.stl`, `JOB.STL`) are an error
    naming both."""
    job = Path(job_path)
    try:
        files = [p for p in job.parent.iterdir() if p.is_file()]
    except OSError:
        return None
    for suffix in BESIDE_SUFFIXES:
        name = (job.stem + suffix).lower()
        found = sorted(p for p in files if p.name.lower() == name)
        if len(found) > 1:
            raise PathcheckError(
                f"more than one part beside the job ({', '.join(p.name for p in found)}): "
                "expected one, or --part PATH", path=job, code="part")
        if found:
            return found[0]
    return None


def load_part(path: str | Path, geometry: GeometryConfig | None = None) -> Part:
    """Read a part file (kind from its suffix); cached in memory by (path, content sha256).
    STEP and IGES are read in a contained child process under the time and memory limits of
    `geometry` (default: the shipped config), see `reader_limits`.

    Raises PathcheckError(code="part") naming the file when it is missing, unreadable, of an
    unsupported kind, holds no usable surface or a number out of its sane range
    (`checker.geometry.part_limits`), or when its reader crashes or passes a limit.
    """
    path = Path(path)
    kind = _READERS.get(path.suffix.lower())
    if kind is None:
        raise PathcheckError(
            f"unsupported part file type '{path.suffix}', expected one of "
            f"{', '.join(sorted(_READERS))}",
            path=path,
            code="part",
        )
    raw = read_input(path, "part file", code="part")
    digest = hashlib.sha256(raw).hexdigest()
    key = (str(path.resolve()), digest)
    if key in _CACHE:
        return _CACHE[key]
    cfg = geometry or default_config().geometry
    part = _read(kind, path, raw, digest, reader_limits(cfg, len(raw)))
    if len(_CACHE) >= _CACHE_MAX:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = part
    return part


def reader_limits(cfg: GeometryConfig, size_bytes: int) -> Limits:
    """Limits of the contained STEP/IGES reader for a file of `size_bytes`: `reader_time_s`
    plus `reader_time_s_per_mb` per MB (2**20 bytes) of wall-clock time, `reader_memory_mb`
    of address space."""
    seconds = cfg.reader_time_s + cfg.reader_time_s_per_mb * size_bytes / 2**20
    return Limits(seconds=seconds, memory_mb=cfg.reader_memory_mb)


def _read(kind: str, path: Path, raw: bytes, digest: str, limits: Limits) -> Part:
    if kind == "stl":
        from checker.geometry.stl_io import read_stl

        mesh = read_stl(path, raw)
        check_mesh(mesh, path)
        return Part(surfaces=[], source=str(path), content_hash=digest, mesh=mesh)
    if kind == "geomdl":
        from checker.geometry.geomdl_io import read_geomdl

        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as err:
            raise PathcheckError(
                "geomdl exchange file is not UTF-8 text", path=path, code="part"
            ) from err
        surfaces = read_geomdl(path, text)
        faces = len(surfaces)
    else:
        from checker.geometry.occ_io import read_occ

        surfaces, faces = read_occ(path, kind, limits)
    if not surfaces:
        raise PathcheckError("no surface found in the part file", path=path, code="part")
    for s in surfaces:
        check_surface(s, path)
    return Part(surfaces=surfaces, source=str(path), content_hash=digest, faces=faces)
