"""Allowable-cutter maps (thesis ch. 4): the allowable size at an iso-parametric grid of CC
points on every surface, and at each point the largest standard cutter of the tool library
that does not exceed it; pictures drawn with matplotlib (Agg) like thesis figs 3-2, 4-2, 4-3."""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from checker.atomic import write_file
from checker.engine.api import allowable
from checker.geometry.evaluate import evaluate
from checker.geometry.sampling import TestPoints
from checker.part import Part
from checker.tool_library import largest_fitting


@dataclass
class SurfaceMap:
    """One surface's grid: `u (nu,)`, `v (nv,)`, `kept (nu, nv)` (inside the trim), `cc`,
    `normal (nu, nv, 3)` part frame, `size (nu, nv)` allowable (mm, inf unbounded, nan not
    kept), `standard (nu, nv)` index into the tool list (-1 none fits)."""

    id: int
    name: str
    u: np.ndarray
    v: np.ndarray
    kept: np.ndarray
    cc: np.ndarray
    normal: np.ndarray
    size: np.ndarray
    standard: np.ndarray


def allowable_maps(part: Part, tp: TestPoints, cutter, grid: tuple[int, int], tools: list,
                   axis=(0.0, 0.0, 1.0)) -> list[SurfaceMap]:
    """Maps of every surface on a `grid` (nu, nv) of (u, v); `tools` the standard cutters of
    the family, ascending by size. One batched engine call for all surfaces."""
    nu, nv = grid
    sizes = np.array([t.size for t in tools], dtype=float)
    grids, rows_cc, rows_n, rows_s, rows_uv = [], [], [], [], []
    for s in part.surfaces:
        (u0, u1), (v0, v1) = s.domain
        u, v = np.linspace(u0, u1, nu), np.linspace(v0, v1, nv)
        U, V = np.meshgrid(u, v, indexing="ij")
        kept = np.ones(U.shape, bool) if s.trim is None else \
            np.asarray(s.trim.contains(U.ravel(), V.ravel()), bool).reshape(U.shape)
        ev = evaluate(s, U.ravel(), V.ravel())
        grids.append((s, u, v, kept, ev.points.reshape(nu, nv, 3), ev.normals.reshape(nu, nv, 3)))
        k = kept.ravel()
        rows_cc.append(ev.points[k])
        rows_n.append(ev.normals[k])
        rows_s.append(np.full(int(k.sum()), s.id))
        rows_uv.append(np.column_stack([U.ravel()[k], V.ravel()[k]]))
    res = allowable(tp, part, cutter, np.concatenate(rows_cc), np.concatenate(rows_n), axis,
                    cc_surface=np.concatenate(rows_s), cc_uv=np.concatenate(rows_uv))
    out, at = [], 0
    for s, u, v, kept, cc, nrm in grids:
        k = int(kept.sum())
        size = np.full(kept.shape, np.nan)
        size[kept] = res.size[at:at + k]
        at += k
        std = largest_fitting(sizes, size)  # nan where not kept: -1
        out.append(SurfaceMap(s.id, s.name, u, v, kept, cc, nrm, size, std))
    return out


def maps_document(maps: list[SurfaceMap], cutter, tools: list) -> dict:
    """JSON view: the cutter, the tools, and per surface the grid with allowable (null =
    unbounded) and the standard cutter name (null = none fits) per kept point."""
    surfaces = []
    for m in maps:
        pts = []
        for i, j in zip(*np.nonzero(m.kept), strict=True):
            s = float(m.size[i, j])
            pts.append({"u": float(m.u[i]), "v": float(m.v[j]),
                        "cc": [round(float(x), 6) for x in m.cc[i, j]],
                        "normal": [round(float(x), 9) for x in m.normal[i, j]],
                        "allowable": round(s, 6) if np.isfinite(s) else None,
                        "standard": (tools[m.standard[i, j]].name if m.standard[i, j] >= 0
                                     else None)})
        surfaces.append({"id": m.id, "name": m.name, "grid": [len(m.u), len(m.v)], "points": pts})
    return {"cutter": cutter.to_apt(), "kind": cutter.kind,
            "tools": [{"name": t.name, "size": t.size} for t in tools], "surfaces": surfaces}


MAP_DPI = 150  # the map pictures print at this dpi; their text is at least 9 pt


def _save_png(fig, path: Path) -> Path:
    """The figure as a PNG file, written atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, dpi=MAP_DPI, format="png")
    return write_file(path, buf.getvalue(), what="map picture")


def size_norm(sizes: np.ndarray):
    """The colour scale of allowable sizes (mm): logarithmic when the positive finite ones span
    a decade or more (as the report's), else linear; over the positive finite sizes."""
    from matplotlib.colors import LogNorm, Normalize

    pos = sizes[np.isfinite(sizes) & (sizes > 0)]
    lo, hi = (float(pos.min()), float(pos.max())) if pos.size else (1.0, 10.0)
    hi = max(hi, lo * 1.001)
    return LogNorm(lo, hi) if hi >= 10.0 * lo else Normalize(lo, hi)


def draw_maps(maps: list[SurfaceMap], cutter, tools: list, out_dir: Path,
              part_name: str) -> list[Path]:
    """`allowable_map.png` (per surface, the allowable size over (u, v), like thesis fig. 3-2;
    unbounded and zero sizes in their own colours) and `standard_map.png` (top view, the
    largest standard cutter per CC point, like figs. 4-2 and 4-3), titled with the part file
    `part_name`, the cutter and the units. Returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    from checker.report.pictures import FONT_PT, STANDARD_NONE, UNBOUNDED

    out_dir.mkdir(parents=True, exist_ok=True)
    var = cutter.size_symbol
    what = f"{cutter.kind} cutter {cutter.to_apt()} on {part_name}"
    norm = size_norm(np.concatenate([m.size.ravel() for m in maps]))
    scale = "log scale" if isinstance(norm, matplotlib.colors.LogNorm) else "linear scale"
    marks = {"unbounded": ListedColormap([UNBOUNDED]), "0: none fits": ListedColormap(
        [STANDARD_NONE])}
    n = len(maps)
    cols = min(3, n)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols + 1.2, 3.2 * rows + 0.8),
                             squeeze=False, layout="constrained")
    for ax, m in zip(axes.ravel(), maps, strict=False):
        shown = np.where(np.isfinite(m.size) & (m.size > 0), m.size, np.nan)
        im = ax.pcolormesh(m.u, m.v, np.clip(shown, norm.vmin, norm.vmax).T, shading="nearest",
                           cmap="viridis", norm=norm)
        for mask, cmap in zip((np.isinf(m.size), m.size <= 0), marks.values(), strict=True):
            if mask.any():
                ax.pcolormesh(m.u, m.v, np.where(mask, 0.0, np.nan).T, shading="nearest",
                              cmap=cmap, vmin=0.0, vmax=1.0)
        ax.set_title(f"surface {m.id}: {m.name}", fontsize=FONT_PT + 1)
        ax.set_xlabel("u", fontsize=FONT_PT + 1)
        ax.set_ylabel("v", fontsize=FONT_PT + 1)
        ax.tick_params(labelsize=FONT_PT)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    bar = fig.colorbar(im, ax=axes.ravel().tolist())
    bar.set_label(f"allowable {var}, mm ({scale})", fontsize=FONT_PT + 1)
    bar.ax.tick_params(labelsize=FONT_PT)
    fig.legend(handles=[Patch(color=c(0), label=k) for k, c in marks.items()],
               loc="outside lower center", ncol=2, fontsize=FONT_PT, frameon=False)
    fig.suptitle(f"allowable {var} (mm) per CC point\n{what}", fontsize=FONT_PT + 2)
    f1 = _save_png(fig, out_dir / "allowable_map.png")
    plt.close(fig)

    colours = [STANDARD_NONE] + list(
        plt.get_cmap("turbo")(np.linspace(0.1, 0.8, max(len(tools), 1))))  # red: none
    cmap = ListedColormap(colours[: len(tools) + 1])
    norm = BoundaryNorm(np.arange(-1.5, len(tools)), cmap.N)
    fig, ax = plt.subplots(figsize=(8, 5.5), layout="constrained")
    for m in maps:
        k = m.kept
        ax.scatter(m.cc[..., 0][k], m.cc[..., 1][k], c=m.standard[k], cmap=cmap, norm=norm, s=12,
                   marker="s", linewidths=0)
    handles = [Patch(color=colours[0], label="none fits")]
    handles += [Patch(color=colours[i + 1], label=f"{t.name} ({var} {t.size:.4g})")
                for i, t in enumerate(tools)]
    ax.legend(handles=handles, fontsize=FONT_PT, loc="upper left", bbox_to_anchor=(1.02, 1.0),
              ncol=1 + len(handles) // 16, frameon=False, borderaxespad=0.0)
    ax.set_aspect("equal")
    ax.set_xlabel("x, mm", fontsize=FONT_PT + 1)
    ax.set_ylabel("y, mm", fontsize=FONT_PT + 1)
    ax.tick_params(labelsize=FONT_PT)
    fig.suptitle(f"largest standard cutter per CC point, top view\n{what}",
                 fontsize=FONT_PT + 2)
    f2 = _save_png(fig, out_dir / "standard_map.png")
    plt.close(fig)
    return [f1, f2]
