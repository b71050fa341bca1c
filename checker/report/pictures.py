"""The report's pictures, drawn with matplotlib's Agg backend and returned as base64 PNG so the
page is self-contained. Per job four pictures, each its own figure (constrained layout, so no
label overlaps another). Drawing text is the cost, so every figure's frame, colour bar, legends
and axes are drawn once per kind of content (family of standard cutters, path-panel scale) and
only the data is drawn on top per job (blitting); the titles are the page's captions:

1. allowable-cutter colour map over the CC points (thesis fig. 3-2), log scale in mm, unbounded
   points in their own colour;
2. standard-cutter colour map (thesis figs 4-2, 4-3): the largest standard cutter per CC point;
3. where the findings are on the part: poses and moves with gouges, interference, holder hits
   and crashes highlighted;
4. B chosen against best B along the path (degrees over % of path length, on one of a few fixed
   B scales); for a job without B, the allowable size along the path against the real cutter
   size (log scale, mm).

Pictures are `PANEL_IN` inches at the configured dpi; the page shows them at that size (96 CSS
px per inch), so text of `FONT_PT` points is FONT_PT * 96 / 72 px on screen. Maps are projected
views of the part frame onto the two coordinates with the largest spread.

The pictures of `pathcheck map` (`draw_maps`: allowable size per surface over (u, v), largest
standard cutter per CC point from the top) are drawn here too, in the same colours: one
unbounded colour, one "none fits" colour, the standard cutters small to large on viridis."""

from __future__ import annotations

import base64
import io
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.cm import ScalarMappable  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm, Normalize  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from PIL import Image  # noqa: E402

from checker.atomic import write_file  # noqa: E402
from checker.report.standard import StandardCutters  # noqa: E402
from checker.results import VERDICTS  # noqa: E402
from checker.verdict import is_finding  # noqa: E402

PANEL_IN = (5.6, 3.9)  # width, height of one picture, inches (shown 538 x 374 CSS px)
TREND_IN = (9.0, 3.0)  # the trend picture, inches
CSS_PX_PER_IN = 96  # the page shows a picture of w inches w * 96 CSS px wide
FONT_PT = 9.0  # tick labels and legends (12 CSS px on the page); axis labels 1 pt larger
ALLOWABLE_RANGE = (0.5, 50.0)  # mm, the fixed colour scale so that jobs compare at a glance
UNBOUNDED = "#e377c2"  # allowable map: no point of the part limits the cutter
VERDICT_COLOURS = {
    "ok": "#c8c8c8", "gouge": "#d62728", "interference": "#ff7f0e", "holder": "#9467bd",
    "inaccessible": "#000000", "within_tolerance": "#8fbc8f", "crash": "#8b0000",
    "machine": "#1f77b4",
}
STANDARD_NONE = "#d62728"  # no standard cutter fits
B_RANGES = (10.0, 30.0, 60.0, 90.0, 180.0)  # degrees: the fixed scales of the B panel
AXES = "XYZ"
# per verdict code (the store's: an index into VERDICTS) whether it is a finding, by the one rule
FINDING_BY_CODE = is_finding(np.array(VERDICTS, dtype=object))
MAP_DPI = 150  # the `pathcheck map` pictures print at this dpi; their text is at least 9 pt

if TYPE_CHECKING:
    from checker.engine.maps import SurfaceMap


def png_base64(rgba: np.ndarray, dpi: float) -> str:
    """A (H, W, 4) uint8 image (a figure's pixels) as base64 PNG text, encoded by Pillow
    (matplotlib's own image library) with a palette of 256 colours (a third of the bytes of
    RGB: a night of 200 jobs is a page of about 18 MB, not 54), its dpi recorded for
    printing."""
    buf = io.BytesIO()
    image = Image.frombuffer("RGBA", (rgba.shape[1], rgba.shape[0]), np.ascontiguousarray(rgba),
                             "raw", "RGBA", 0, 1)
    image.convert("RGB").quantize(256, method=Image.Quantize.FASTOCTREE).save(
        buf, "PNG", dpi=(dpi, dpi))
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _projection(cc: np.ndarray) -> tuple[int, int]:
    """The two coordinates of cc (N,3) with the largest spread, in axis order."""
    spread = np.ptp(cc, axis=0) if len(cc) else np.ones(3)
    i, j = sorted(np.argsort(spread)[1:])
    return int(i), int(j)


def path_length(cc: np.ndarray) -> np.ndarray:
    """(N,) cumulative length (mm) of the polyline through the points cc (N,3)."""
    if len(cc) == 0:
        return np.zeros(0)
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(cc, axis=0), axis=1))])


def paint_map(
    target: np.ndarray, xy: np.ndarray, rgba: np.ndarray, size: np.ndarray, order: np.ndarray,
    view: tuple[np.ndarray, float] | None = None,
) -> None:
    """Paint points xy (N,2, mm) as filled squares of `size` (N,) pixels and colour rgba (N,4,
    uint8) onto `target` (H, W, 4, uint8, row 0 at the top), white first, fitted square and
    padded around the points, or around `view` (centre (2,) mm, half-width mm) when given so
    that maps of one job share their scale. `order` (N,) int: higher groups are painted
    later, on top."""
    target[:] = 255
    if len(xy) == 0:
        return
    h, w = target.shape[:2]
    px = min(h, w)
    centre, half = view if view is not None else _view(xy)
    x0, y0 = centre - half
    col = (w - px) // 2 + ((xy[:, 0] - x0) / (2 * half) * (px - 1)).astype(int)
    row = (h + px) // 2 - 1 - ((xy[:, 1] - y0) / (2 * half) * (px - 1)).astype(int)
    for group in np.unique(order):  # a few groups; each vectorised over its points
        sel = np.nonzero(order == group)[0]
        d = np.arange(int(size[sel].max())) - int(size[sel].max()) // 2
        rr = np.clip(row[sel, None, None] + d[None, :, None], 0, h - 1)
        cc = np.clip(col[sel, None, None] + d[None, None, :], 0, w - 1)
        target[rr, cc] = rgba[sel, None, None]


def _view(xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (2,) and half-width (mm) of the square view around the points xy (N,2)."""
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    return 0.5 * (lo + hi), 0.53 * max(float(np.max(hi - lo)), 1e-6)


def _rgba_bytes(colours: list) -> np.ndarray:
    """(K, 4) uint8 RGBA of matplotlib colour specs."""
    return (255 * np.array([matplotlib.colors.to_rgba(c) for c in colours]) + 0.5).astype(np.uint8)


def standard_colours(count: int) -> np.ndarray:
    """(count+1, 4) uint8 RGBA: 'none fits' red, then `count` standard cutters small to large
    on the allowable map's colour scale (bright = large)."""
    steps = matplotlib.colormaps["viridis"](np.linspace(0.05, 1.0, count), bytes=True)
    return np.vstack([_rgba_bytes([STANDARD_NONE]), steps])


def b_range(values: np.ndarray) -> float:
    """The smallest of the fixed B scales (degrees, symmetric) that holds all finite values."""
    finite = np.abs(values[np.isfinite(values)])
    top = float(finite.max()) if len(finite) else 0.0
    return next((r for r in B_RANGES if top <= r), B_RANGES[-1])


class _Drawn:
    """One figure drawn once (its background kept) and where the data goes on it: the map's
    pixel box (rows r0:r1, columns c0:c1) or the path panel's lines."""

    def __init__(self, fig: Figure, ax, lines: tuple = ()) -> None:
        fig.canvas.draw()
        self.fig, self.lines = fig, lines
        self.background = fig.canvas.copy_from_bbox(fig.bbox)
        b, height = ax.bbox, fig.bbox.height
        self.box = (int(height - b.y1) + 2, int(height - b.y0) - 1, int(b.x0) + 2, int(b.x1) - 1)

    def restored(self) -> np.ndarray:
        """The figure's pixels (H, W, 4, a writable view) with the background restored."""
        self.fig.canvas.restore_region(self.background)
        return np.asarray(self.fig.canvas.buffer_rgba())


class JobPainter:
    """Draws the four pictures of a job; one instance per process, reused for every job. Each
    picture's figure is drawn once per content key (the allowable variable r or R, the family
    of standard cutters, the path panel's scale) and kept."""

    def __init__(self, dpi: int = 150) -> None:
        self.dpi = dpi
        self.allow_cmap = matplotlib.colormaps["viridis"]
        self.allow_norm = LogNorm(*ALLOWABLE_RANGE)
        self.verdict_rgba = _rgba_bytes([VERDICT_COLOURS[v] for v in VERDICTS])
        self.unbounded_rgba = _rgba_bytes([UNBOUNDED])[0]
        self.drawn: dict[tuple, _Drawn] = {}

    def _figure(self) -> tuple[Figure, object]:
        fig = Figure(figsize=PANEL_IN, dpi=self.dpi, layout="constrained")
        FigureCanvasAgg(fig)
        return fig, fig.add_subplot()

    def _map_figure(self, handles: list, ncol: int = 1) -> tuple[Figure, object]:
        """A map panel: a frame without ticks, and a legend of `handles` on its right."""
        fig, ax = self._figure()
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_aspect("equal")
        fig.legend(handles=handles, loc="outside right upper", fontsize=FONT_PT, ncol=ncol,
                   frameon=False, handlelength=1.0, labelspacing=0.3, columnspacing=0.8)
        return fig, ax

    def _allowable(self, symbol: str) -> _Drawn:
        if ("allowable", symbol) not in self.drawn:
            fig, ax = self._map_figure([Patch(color=UNBOUNDED, label="unbounded")])
            bar = fig.colorbar(ScalarMappable(self.allow_norm, self.allow_cmap), ax=ax,
                               location="left", shrink=0.9)
            bar.set_label(f"allowable {symbol}, mm (log)", fontsize=FONT_PT + 1)
            bar.ax.tick_params(labelsize=FONT_PT)
            self.drawn["allowable", symbol] = _Drawn(fig, ax)
        return self.drawn["allowable", symbol]

    def _standard(self, names: tuple[str, ...]) -> _Drawn:
        if ("standard", names) not in self.drawn:
            colours = standard_colours(len(names)) / 255.0
            handles = [Patch(color=c, label=n) for c, n in
                       zip(colours[::-1], [*names[::-1], "none"], strict=True)]
            fig, ax = self._map_figure(handles, ncol=1 + len(handles) // 13)
            self.drawn["standard", names] = _Drawn(fig, ax)
        return self.drawn["standard", names]

    def _findings(self) -> _Drawn:
        if "findings" not in self.drawn:
            fig, ax = self._map_figure(
                [Patch(color=VERDICT_COLOURS[v], label=v.replace("_", " ")) for v in VERDICTS])
            self.drawn["findings"] = _Drawn(fig, ax)
        return self.drawn["findings"]

    def _path(self, scale: float | str) -> _Drawn:
        """The path panel on a scale: a B range (degrees) or 'size' (log, mm)."""
        if ("path", scale) not in self.drawn:
            fig, ax = self._figure()
            ax.set_xlim(0.0, 100.0)
            ax.xaxis.set_major_locator(MaxNLocator(5))
            ax.tick_params(labelsize=FONT_PT)
            ax.set_xlabel("position along the path, % of its length", fontsize=FONT_PT + 1)
            a = ax.plot([], [], ".", ms=3, color="#1f77b4", animated=True)[0]
            b = ax.plot([], [], "-", lw=1.4, color="#ff7f0e", animated=True)[0]
            limit = ax.plot([], [], "--", lw=1.2, color="#d62728", animated=True)[0]
            top = ax.plot([], [], "^", ms=4, color=UNBOUNDED, animated=True, clip_on=False)[0]
            if scale == "size":
                ax.set_yscale("log")
                ax.set_ylim(*ALLOWABLE_RANGE)
                ax.set_ylabel("size, mm", fontsize=FONT_PT + 1)
                handles, labels = (a, limit, top), ("allowable", "real size", "unbounded")
            else:
                ax.set_ylim(-scale, scale)
                ax.yaxis.set_major_locator(MaxNLocator(5, symmetric=True))
                ax.set_ylabel("B, degrees", fontsize=FONT_PT + 1)
                handles, labels = (a, b), ("best B", "chosen B")
            fig.legend(handles, labels, fontsize=FONT_PT, loc="outside upper center", ncol=2,
                       frameon=False, handlelength=1.5)
            self.drawn["path", scale] = _Drawn(fig, ax, (a, b, limit, top))
        return self.drawn["path", scale]

    def _png(self, drawn: _Drawn, xy: np.ndarray, rgba: np.ndarray, size: np.ndarray,
             order: np.ndarray, view: tuple[np.ndarray, float]) -> str:
        img = drawn.restored()
        r0, r1, c0, c1 = drawn.box
        paint_map(img[r0:r1, c0:c1], xy, rgba, size, order, view)
        return png_base64(img, self.dpi)

    def render(
        self, arrays: dict[str, np.ndarray], standard: StandardCutters, cutter_size: float | None,
        symbol: str,
    ) -> tuple[list[str], dict]:
        """The four pictures (base64 PNG) of one job from its point arrays (see
        `checker.store.point_arrays`; the two cutter maps over the cutting poses with a
        contact, the findings map over all) and facts for their captions: view, extent (mm),
        has_b, highlighted (findings drawn), symbol (the allowable variable, r or R)."""
        cl, verdict = arrays["contact"], arrays["verdict"]
        i, j = _projection(arrays["cc"])
        xy = arrays["cc"][:, [i, j]]
        view = _view(xy) if len(xy) else (np.zeros(2), 1.0)
        allow = self._allowable(symbol)
        map_px = allow.box[1] - allow.box[0]
        dot = max(3, min(12, int(0.8 * map_px / np.sqrt(max(int(cl.sum()), 1)))))
        allowable = arrays["allowable"][cl]
        unbounded = np.isnan(allowable)
        allow_rgba = self.allow_cmap(
            self.allow_norm(np.clip(np.nan_to_num(allowable, nan=1.0), *ALLOWABLE_RANGE)),
            bytes=True,
        )
        allow_rgba[unbounded] = self.unbounded_rgba
        std_rgba = standard_colours(len(standard.names))[standard.largest(allowable) + 1]
        flat, n = np.full(int(cl.sum()), dot), np.zeros(int(cl.sum()), dtype=int)
        found = FINDING_BY_CODE[verdict].astype(int)
        pictures = [
            self._png(allow, xy[cl], allow_rgba, flat, n, view),
            self._png(self._standard(standard.names), xy[cl], std_rgba, flat, n, view),
            self._png(self._findings(), xy, self.verdict_rgba[verdict], dot + 3 * found, found,
                      view),
        ]
        path, scale = self._path_panel(arrays, cutter_size)
        path.restored()
        for line in path.lines:
            path.fig.draw_artist(line)
        pictures.append(png_base64(np.asarray(path.fig.canvas.buffer_rgba()), self.dpi))
        extent = np.ptp(xy, axis=0) if len(xy) else np.zeros(2)
        facts = {"view": f"{AXES[i]}{AXES[j]}", "extent": [float(extent[0]), float(extent[1])],
                 "has_b": scale != "size", "highlighted": int(found.sum()), "symbol": symbol}
        return pictures, facts

    def _path_panel(
        self, arrays: dict[str, np.ndarray], cutter_size: float | None
    ) -> tuple[_Drawn, float | str]:
        """The path panel for this job with its lines' data set, and its scale (B range,
        degrees, or 'size')."""
        cc_only = arrays["kind"]
        s = path_length(arrays["cc"][cc_only])
        s = 100.0 * s / max(float(s[-1]), 1e-9) if len(s) else s
        b_best, b_chosen = arrays["b_best"][cc_only], arrays["b_chosen"][cc_only]
        if np.isfinite(b_chosen).any() or np.isfinite(b_best).any():
            scale = b_range(np.concatenate([b_best, b_chosen]))
            data = ((s, b_best), (s, b_chosen), ([], []), ([], []))
        else:
            scale = "size"
            allowable = arrays["allowable"][cc_only]
            unbounded = np.isnan(allowable) & arrays["contact"][cc_only]
            data = ((s, allowable), ([], []), ([0.0, 100.0], [cutter_size or np.nan] * 2),
                    (s[unbounded], np.full(int(unbounded.sum()), ALLOWABLE_RANGE[1])))
        drawn = self._path(scale)
        for line, (x, y) in zip(drawn.lines, data, strict=True):
            line.set_data(x, y)
        return drawn, scale


def trend_picture(nights: list[dict], dpi: int = 150) -> str:
    """Jobs per night (stacked ok / findings / failed) and finding points per night, as one
    base64 PNG; `nights` are dicts with keys night (YYYY-MM-DD), ok, findings, failed, gouges."""
    fig = Figure(figsize=TREND_IN, dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    x = np.arange(len(nights))
    bottom = np.zeros(len(nights))
    for key, colour in (("ok", "#2ca02c"), ("findings", "#ff7f0e"), ("failed", "#d62728")):
        v = np.array([n[key] for n in nights], dtype=float)
        ax.bar(x, v, bottom=bottom, color=colour, label=f"jobs {key}", width=0.7)
        bottom += v
    ax.set_ylabel("jobs", fontsize=FONT_PT + 1)
    ax.set_xticks(x, [n["night"][5:] for n in nights], fontsize=FONT_PT, rotation=45)
    ax.tick_params(labelsize=FONT_PT)
    ax.yaxis.set_major_locator(MaxNLocator(5, integer=True))
    ax2 = ax.twinx()
    ax2.plot(x, [n["gouges"] for n in nights], "k.-", label="gouge points")
    ax2.set_ylabel("gouge points", fontsize=FONT_PT + 1)
    ax2.tick_params(labelsize=FONT_PT)
    ax2.set_ylim(bottom=0)
    fig.legend(fontsize=FONT_PT, loc="outside upper center", ncol=4, frameon=False)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def size_norm(sizes: np.ndarray) -> Normalize:
    """The colour scale of allowable sizes (mm) of `pathcheck map`: logarithmic when the
    positive finite ones span a decade or more (as the report's), else linear; over the
    positive finite sizes."""
    pos = sizes[np.isfinite(sizes) & (sizes > 0)]
    lo, hi = (float(pos.min()), float(pos.max())) if pos.size else (1.0, 10.0)
    hi = max(hi, lo * 1.001)
    return LogNorm(lo, hi) if hi >= 10.0 * lo else Normalize(lo, hi)


def _save_png(fig: Figure, path: Path) -> Path:
    """The figure as a PNG file of MAP_DPI, written atomically."""
    buf = io.BytesIO()
    fig.savefig(buf, dpi=MAP_DPI, format="png")
    return write_file(path, buf.getvalue(), what="map picture")


def draw_maps(maps: list[SurfaceMap], cutter, tools: list, out_dir: Path,
              part_name: str) -> list[Path]:
    """`allowable_map.png` (per surface, the allowable size over (u, v), like thesis fig. 3-2;
    unbounded and zero sizes in their own colours) and `standard_map.png` (top view, the
    largest standard cutter per CC point, like figs. 4-2 and 4-3), titled with the part file
    `part_name`, the cutter and the units. Returns the files written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    var = cutter.size_symbol
    what = f"{cutter.kind} cutter {cutter.to_apt()} on {part_name}"
    norm = size_norm(np.concatenate([m.size.ravel() for m in maps]))
    scale = "log scale" if isinstance(norm, LogNorm) else "linear scale"
    marks = {"unbounded": ListedColormap([UNBOUNDED]),
             "0: none fits": ListedColormap([STANDARD_NONE])}
    n = len(maps)
    cols = min(3, n)
    rows = (n + cols - 1) // cols
    fig = Figure(figsize=(3.6 * cols + 1.2, 3.2 * rows + 0.8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False)
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

    colours = standard_colours(len(tools)) / 255.0
    cmap = ListedColormap(colours)
    fig = Figure(figsize=(8, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    for m in maps:
        k = m.kept
        ax.scatter(m.cc[..., 0][k], m.cc[..., 1][k], c=m.standard[k], cmap=cmap,
                   norm=BoundaryNorm(np.arange(-1.5, len(tools)), cmap.N), s=12, marker="s",
                   linewidths=0)
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
    return [f1, _save_png(fig, out_dir / "standard_map.png")]
