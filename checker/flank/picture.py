"""The error map picture: the envelope's error over the design surface's (u, v), before and
(when optimised) after, on one diverging colour scale (mm, > 0 overcut)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import io  # noqa: E402

import numpy as np  # noqa: E402
from matplotlib.colors import TwoSlopeNorm  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from checker.atomic import write_file  # noqa: E402
from checker.flank.error_document import ErrorMap  # noqa: E402


def _grid(m: ErrorMap) -> np.ndarray:
    return np.array([[np.nan if x is None else x for x in row] for row in m.error], dtype=float)


def draw_error_map(maps: list[tuple[str, ErrorMap]], path: Path, title: str) -> Path:
    """A PNG with one panel per (label, map), colour = error mm over (u, v); returns `path`."""
    grids = [_grid(m) for _, m in maps]
    finite = np.concatenate([g[np.isfinite(g)] for g in grids] + [np.zeros(1)])
    top = max(float(np.abs(finite).max()), 1e-6)
    norm = TwoSlopeNorm(vcenter=0.0, vmin=-top, vmax=top)
    fig = Figure(figsize=(5.0 * len(maps) + 1.0, 4.5))
    axes = fig.subplots(1, len(maps), squeeze=False)[0]
    image = None
    for ax, (label, m), g in zip(axes, maps, grids, strict=True):
        image = ax.pcolormesh(m.u, m.v, g.T, cmap="RdBu_r", norm=norm, shading="nearest")
        finite_g = g[np.isfinite(g)]
        peak = float(np.abs(finite_g).max()) if finite_g.size else 0.0
        ax.set_title(f"{label}: max |error| {peak * 1000:.1f} um", fontsize=9)
        ax.set_xlabel("u")
        ax.set_ylabel("v")
    fig.colorbar(image, ax=list(axes), label="error mm (> 0 overcut, < 0 undercut)")
    fig.suptitle(title, fontsize=9)
    buf = io.BytesIO()
    fig.savefig(buf, dpi=110, format="png")
    return write_file(path, buf.getvalue(), what="error map picture")
