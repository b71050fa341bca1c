"""The report's pictures, drawn with matplotlib's Agg backend and returned as base64 PNG so the
page is self-contained. Per job, four panels of one reused figure (drawing text is the cost, so
the frames, colour bar, legends and axes are drawn once and only the data changes between jobs;
the titles are the page's captions):

1. allowable-cutter colour map over the CC points (thesis fig. 3-2), log scale in mm;
2. standard-cutter colour map (thesis figs 4-2, 4-3): the largest standard cutter per CC point;
3. where the findings are on the part: CC points with gouges, interference and holder hits
   highlighted;
4. B chosen against best B along the path (degrees over % of path length, on one of a few fixed
   B scales); for a job without B, the allowable size along the path against the real cutter
   size (log scale, mm).

Maps are projected views of the part frame onto the two coordinates with the largest spread."""

from __future__ import annotations

import base64
import struct
import zlib

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.cm import ScalarMappable  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from checker.report.standard import StandardCutters  # noqa: E402
from checker.results import VERDICTS  # noqa: E402

PANEL_PX = (330, 270)  # width, height of one picture, pixels
ALLOWABLE_RANGE = (0.5, 50.0)  # mm, the fixed colour scale so that jobs compare at a glance
VERDICT_COLOURS = {
    "ok": "#c8c8c8", "gouge": "#d62728", "interference": "#ff7f0e", "holder": "#9467bd",
    "inaccessible": "#000000", "within_tolerance": "#8fbc8f", "crash": "#8b0000",
}
STANDARD_NONE = "#d62728"  # no standard cutter fits
B_RANGES = (10.0, 30.0, 60.0, 90.0, 180.0)  # degrees: the fixed scales of the B panel
AXES = "XYZ"


def png_base64(rgba: np.ndarray) -> str:
    """A (H, W, 4) uint8 image as base64 PNG text (RGB, no row filter, fast zlib level)."""
    h, w = rgba.shape[:2]
    raw = np.zeros((h, 1 + 3 * w), dtype=np.uint8)  # each row: filter byte 0, then RGB
    raw[:, 1:].reshape(h, w, 3)[:] = rgba[:, :, :3]

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    png = b"".join((
        b"\x89PNG\r\n\x1a\n",
        chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)),
        chunk(b"IDAT", zlib.compress(raw.tobytes(), 1)),
        chunk(b"IEND", b""),
    ))
    return base64.b64encode(png).decode("ascii")


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
    target: np.ndarray, xy: np.ndarray, rgba: np.ndarray, size: np.ndarray, order: np.ndarray
) -> None:
    """Paint points xy (N,2, mm) as filled squares of `size` (N,) pixels and colour rgba (N,4,
    uint8) onto `target` (H, W, 4, uint8, row 0 at the top), white first, fitted square and
    padded around the points. `order` (N,) int: higher groups are painted later, on top."""
    target[:] = 255
    if len(xy) == 0:
        return
    h, w = target.shape[:2]
    px = min(h, w)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    half = 0.53 * max(float(np.max(hi - lo)), 1e-6)
    x0, y0 = 0.5 * (lo + hi) - half
    col = (w - px) // 2 + ((xy[:, 0] - x0) / (2 * half) * (px - 1)).astype(int)
    row = (h + px) // 2 - 1 - ((xy[:, 1] - y0) / (2 * half) * (px - 1)).astype(int)
    for group in np.unique(order):  # a few groups; each vectorised over its points
        sel = np.nonzero(order == group)[0]
        d = np.arange(int(size[sel].max())) - int(size[sel].max()) // 2
        rr = np.clip(row[sel, None, None] + d[None, :, None], 0, h - 1)
        cc = np.clip(col[sel, None, None] + d[None, None, :], 0, w - 1)
        target[rr, cc] = rgba[sel, None, None]


def _rgba_bytes(colours: list) -> np.ndarray:
    """(K, 4) uint8 RGBA of matplotlib colour specs."""
    return (255 * np.array([matplotlib.colors.to_rgba(c) for c in colours]) + 0.5).astype(np.uint8)


def b_range(values: np.ndarray) -> float:
    """The smallest of the fixed B scales (degrees, symmetric) that holds all finite values."""
    finite = np.abs(values[np.isfinite(values)])
    top = float(finite.max()) if len(finite) else 0.0
    return next((r for r in B_RANGES if top <= r), B_RANGES[-1])


class JobPainter:
    """Draws the four pictures of a job; one instance per process, reused for every job.

    Everything but the data is drawn once into a background per family of standard cutters and
    path-panel scale (frames, colour bar, legends, the path panel's axes for each fixed B range
    and for the size scale); per job only the map images and the path lines are drawn on top
    (blitting), so no text is laid out per job."""

    def __init__(self, dpi: int = 72) -> None:
        w, h = PANEL_PX
        self.fig = Figure(figsize=(4 * w / dpi, h / dpi), dpi=dpi)
        FigureCanvasAgg(self.fig)
        top, bottom = 0.95, 0.07
        side = (top - bottom) * h / (4 * w)  # square map axes, as a fraction of figure width
        maps = [self.fig.add_axes((k / 4 + 0.006, bottom, side, top - bottom)) for k in range(3)]
        for ax in maps:
            ax.set_xticks([])
            ax.set_yticks([])
        height = self.fig.bbox.height
        self.map_boxes = [  # pixel rows and columns inside each map's frame
            (int(height - b.y1) + 2, int(height - b.y0) - 1, int(b.x0) + 2, int(b.x1) - 1)
            for b in (ax.bbox for ax in maps)
        ]
        self.allow_cmap = matplotlib.colormaps["viridis"]
        self.allow_norm = LogNorm(*ALLOWABLE_RANGE)
        cax = self.fig.add_axes((0.006 + side + 0.004, bottom, 0.008, top - bottom))
        bar = self.fig.colorbar(ScalarMappable(self.allow_norm, self.allow_cmap), cax=cax)
        bar.set_label("allowable size, mm", fontsize=8)
        cax.tick_params(labelsize=7)
        maps[2].legend(
            handles=[Patch(color=VERDICT_COLOURS[v], label=v) for v in VERDICTS],
            loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False,
        )
        self.verdict_rgba = _rgba_bytes([VERDICT_COLOURS[v] for v in VERDICTS])
        ax = self.fig.add_axes((0.75 + 0.04, bottom + 0.09, 0.2, top - bottom - 0.17))
        ax.set_xlim(0.0, 100.0)
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.tick_params(labelsize=7)
        ax.set_xlabel("position along the path, % of its length", fontsize=8)
        (self.line_a,) = ax.plot([], [], ".", ms=2, color="#1f77b4", animated=True)
        (self.line_b,) = ax.plot([], [], "-", lw=1.2, color="#ff7f0e", animated=True)
        (self.limit,) = ax.plot([], [], "--", lw=1.0, color="#d62728", animated=True)
        self.path_ax = ax
        self.standard_map = maps[1]
        self.backgrounds: dict[tuple, object] = {}
        self._path_scale: float | str | None = None
        self.standard_rgba: dict[tuple[str, ...], np.ndarray] = {}

    def _standard_colours(self, names: tuple[str, ...]) -> np.ndarray:
        """(K+1, 4) uint8: 'none fits' red, then the standard cutters small to large on the
        allowable map's colour scale (bright = large)."""
        if names not in self.standard_rgba:
            steps = self.allow_cmap(np.linspace(0.05, 1.0, len(names)), bytes=True)
            self.standard_rgba[names] = np.vstack([_rgba_bytes([STANDARD_NONE]), steps])
        return self.standard_rgba[names]

    def _scale_path_axes(self, scale: float | str) -> None:
        """Put the path panel on a scale (the lines are drawn with the axes' current one)."""
        if scale == self._path_scale:
            return
        ax = self.path_ax
        if scale == "size":
            ax.set_yscale("log")
            ax.set_ylim(*ALLOWABLE_RANGE)
        else:
            ax.set_yscale("linear")
            ax.set_ylim(-scale, scale)
            ax.yaxis.set_major_locator(MaxNLocator(5, symmetric=True))
        self._path_scale = scale

    def _background(self, names: tuple[str, ...], scale: float | str) -> object:
        """The drawn static figure for a family of standard cutters and a path-panel scale (a B
        range, degrees, or 'size')."""
        if (names, scale) not in self.backgrounds:
            ax = self.path_ax
            for owner in (ax, self.standard_map):
                if owner.get_legend() is not None:
                    owner.get_legend().remove()
            colours = self._standard_colours(names) / 255.0
            self.standard_map.legend(
                handles=[Patch(color=c, label=n) for c, n in
                         zip(colours[::-1], [*names[::-1], "none"], strict=True)],
                loc="upper left", bbox_to_anchor=(1.0, 1.02), fontsize=6 if len(names) < 16
                else 5, frameon=False, handlelength=1.0, labelspacing=0.25,
            )
            self._scale_path_axes(scale)
            if scale == "size":
                ax.set_ylabel("size, mm", fontsize=8)
                handles, labels = (self.line_a, self.limit), ("allowable", "real size")
            else:
                ax.set_ylabel("B, degrees", fontsize=8)
                handles, labels = (self.line_a, self.line_b), ("best B", "chosen B")
            ax.legend(handles, labels, fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0),
                      ncol=2, frameon=False, handlelength=1.5)
            self.fig.canvas.draw()
            self.backgrounds[names, scale] = self.fig.canvas.copy_from_bbox(self.fig.bbox)
        return self.backgrounds[names, scale]

    def render(
        self, arrays: dict[str, np.ndarray], standard: StandardCutters, cutter_size: float | None
    ) -> tuple[list[str], dict]:
        """The four pictures (base64 PNG) of one job from its point arrays (see
        `checker.store.point_arrays`), and facts for their captions: view, extent (mm),
        min_allowable (mm, over the accessible points), findings, has_b."""
        cc, allowable, verdict = arrays["cc"], arrays["allowable"], arrays["verdict"]
        i, j = _projection(cc)
        xy = cc[:, [i, j]]
        map_px = self.map_boxes[0][1] - self.map_boxes[0][0]
        dot = max(2, min(7, int(0.8 * map_px / np.sqrt(max(len(xy), 1)))))
        shown = np.where(np.isnan(allowable), ALLOWABLE_RANGE[1], allowable)
        allow_rgba = self.allow_cmap(
            self.allow_norm(np.clip(shown, *ALLOWABLE_RANGE)), bytes=True
        )
        std_rgba = self._standard_colours(standard.names)[standard.largest(allowable) + 1]
        layers = (
            (allow_rgba, np.zeros(len(xy), dtype=int)), (std_rgba, np.zeros(len(xy), dtype=int)),
            (self.verdict_rgba[verdict], (verdict != 0).astype(int)),
        )
        scale = self._path_lines(arrays, cutter_size)
        canvas = self.fig.canvas
        canvas.restore_region(self._background(standard.names, scale))
        self._scale_path_axes(scale)
        img = np.asarray(canvas.buffer_rgba())
        for (r0, r1, c0, c1), (rgba, group) in zip(self.map_boxes, layers, strict=True):
            paint_map(img[r0:r1, c0:c1], xy, rgba, dot + 3 * group, group)
        for artist in (self.line_a, self.line_b, self.limit):
            self.fig.draw_artist(artist)
        w = img.shape[1] // 4
        extent = np.ptp(xy, axis=0) if len(xy) else np.zeros(2)
        reach = allowable[verdict != VERDICTS.index("inaccessible")]
        facts = {
            "view": f"{AXES[i]}{AXES[j]}", "extent": [float(extent[0]), float(extent[1])],
            "min_allowable": float(np.nanmin(reach)) if np.isfinite(reach).any() else None,
            "findings": int(np.sum(verdict != 0)), "has_b": scale != "size",
        }
        return [png_base64(img[:, k * w : (k + 1) * w]) for k in range(4)], facts

    def _path_lines(self, arrays: dict[str, np.ndarray], cutter_size: float | None) -> float | str:
        """Set the path panel's lines; returns its scale (B range, degrees, or 'size')."""
        cc_only = arrays["kind"]
        s = path_length(arrays["cc"][cc_only])
        s = 100.0 * s / max(float(s[-1]), 1e-9) if len(s) else s
        b_best, b_chosen = arrays["b_best"][cc_only], arrays["b_chosen"][cc_only]
        if np.isfinite(b_chosen).any() or np.isfinite(b_best).any():
            self.line_a.set_data(s, b_best)
            self.line_b.set_data(s, b_chosen)
            self.limit.set_data([], [])
            return b_range(np.concatenate([b_best, b_chosen]))
        allowable = arrays["allowable"][cc_only]
        self.line_a.set_data(s, np.where(np.isnan(allowable), ALLOWABLE_RANGE[1], allowable))
        self.line_b.set_data([], [])
        self.limit.set_data([0.0, 100.0], [cutter_size or np.nan] * 2)
        return "size"


def trend_picture(nights: list[dict], dpi: int = 72) -> str:
    """Jobs per night (stacked ok / findings / failed) and finding points per night, as one
    base64 PNG; `nights` are dicts with keys night (YYYY-MM-DD), ok, findings, failed, gouges."""
    fig = Figure(figsize=(9.0, 2.8), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.07, 0.22, 0.80, 0.66))
    x = np.arange(len(nights))
    bottom = np.zeros(len(nights))
    for key, colour in (("ok", "#2ca02c"), ("findings", "#ff7f0e"), ("failed", "#d62728")):
        v = np.array([n[key] for n in nights], dtype=float)
        ax.bar(x, v, bottom=bottom, color=colour, label=f"jobs {key}", width=0.7)
        bottom += v
    ax.set_ylabel("jobs", fontsize=8)
    ax.set_xticks(x, [n["night"][5:] for n in nights], fontsize=7, rotation=45)
    ax.tick_params(labelsize=7)
    ax2 = ax.twinx()
    ax2.plot(x, [n["gouges"] for n in nights], "k.-", label="gouge points")
    ax2.set_ylabel("gouge points", fontsize=8)
    ax2.tick_params(labelsize=7)
    ax2.set_ylim(bottom=0)
    fig.legend(fontsize=7, loc="upper left", ncol=4, frameon=False, bbox_to_anchor=(0.07, 1.0))
    fig.canvas.draw()
    return png_base64(np.asarray(fig.canvas.buffer_rgba()))
