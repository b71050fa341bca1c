"""What a job is checked or posted with, resolved from what the caller gave: the config (a
`Config`, a TOML path or the defaults), the part file (given, or beside the CL file), the
machine (given, or the CL file's) and the real cutter of every operation (given, or the CL
file's own)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from checker.config import Config, default_config, load_config
from checker.cutter import Cutter, parse_cutter_in
from checker.errors import PathcheckError
from checker.geometry import BESIDE_SUFFIXES, find_part_beside
from checker.postproc.machine import Machine, load_machine
from checker.postproc.post import machine_for_toolpath
from checker.toolpath import ToolPath


def job_config(config: Config | str | Path | None) -> Config:
    """`config` itself, the defaults merged with the TOML file `config`, or the defaults."""
    if config is None:
        return default_config()
    return config if isinstance(config, Config) else load_config(config)


def part_file(apt_path: Path, given: str | Path | None) -> Path:
    """The part of the job `apt_path`: `given`, else the file beside the job with its stem."""
    if given is not None:
        return Path(given)
    found = find_part_beside(apt_path)
    if found is None:
        raise PathcheckError(
            f"no part given and none beside the job: expected --part PATH, a file "
            f"{apt_path.stem}{{{','.join(BESIDE_SUFFIXES)}}} (any case), or --no-check to "
            "post without checking", path=apt_path, code="part")
    return found


def job_machine(apt_path: Path, given: str | Path | None) -> Machine:
    """The machine job `apt_path` runs on: `given` (a shipped machine's name or a TOML file),
    else its CL file's `PPRINT/MACHINE` (the file is read only then), else the default
    (`machine_for_toolpath`)."""
    from checker.apt import read_cl

    if given is not None:
        return load_machine(given)
    return machine_for_toolpath(read_cl(apt_path, require_cutter=False))


def operation_cutters(toolpath: ToolPath, ops: np.ndarray, cutter: Cutter | str | None,
                      apt_path: Path, cutter_units: str | None = None) -> dict[int, Cutter]:
    """The real cutter of every operation index in `ops`; a `cutter` statement given as text
    is read in `cutter_units` (default: the job's units)."""
    if cutter is not None:
        c = cutter if isinstance(cutter, Cutter) else parse_cutter_in(
            str(cutter), cutter_units or toolpath.units)
        return {int(o): c for o in np.unique(ops)}
    out = {}
    for o in np.unique(ops):
        op = toolpath.operations[int(o)]
        if op.cutter is None:
            rec = toolpath.records[op.first_record] if op.end_record > op.first_record else None
            raise PathcheckError(
                f"operation '{op.name}' has no cutter: expected a CUTTER/ or TLDATA/ statement "
                f"before its moves, or --cutter", path=apt_path,
                line=None if rec is None else rec.line, code="cutter")
        out[int(o)] = op.cutter
    return out
