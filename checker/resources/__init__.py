"""Data shipped inside the package (read with importlib.resources, so that an installed wheel
has them): `defaults.toml` (configuration), `tools.toml` (tool library), `machines/*.toml`,
`schemas/*.json` (published JSON Schemas), `warmup/` (the small job that compiles the
kernels once per install) and, in a wheel, `kernels/` (its portable compiled kernels, built by
`make wheel`, not kept in git: `checker.kernel_cache`)."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def resource(*parts: str) -> Path:
    """The path of a shipped data file or folder (package data is installed as plain files)."""
    return Path(str(files(__name__).joinpath(*parts)))
