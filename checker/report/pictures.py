"""The report's pictures, drawn with matplotlib's Agg backend and returned as base64 PNG so the
page is self-contained. Per job, four panels of one reused figure (drawing is the cost, so the
figure, its colour bar and legends are built once and only the data changes between jobs):

1. allowable-cutter colour map over the CC points (thesis fig. 3-2), log scale in mm;
2. standard-cutter colour map (thesis figs 4-2, 4-3): the largest standard cutter per CC point;
3. where the findings are on the part: CC points with gouges, interference and holder hits
   highlighted;
4. B chosen against best B along the path (degrees over path length, mm); for a job without B,
   the allowable size along the path against the real cutter size.

Maps are projected views of the part frame onto the two coordinates with the largest spread."""

from __future__ import annotations

import base64
import io

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.colors import ListedColormap, LogNorm  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from PIL import Image  # noqa: E402

from checker.report.standard import StandardCutters  # noqa: E402
from checker.results import VERDICTS  # noqa: E402

PANEL_PX = (330, 270)  # width, height of one picture, pixels
ALLOWABLE_RANGE = (0.5, 50.0)  # mm, the fixed colour scale so that jobs compare at a glance
VERDICT_COLOURS = {
    "ok": "#c8c8c8", "gouge": "#d62728", "interference": "#ff7f0e", "holder": "#9467bd",
    "inaccessible": "#000000",
}
STANDARD_NONE = "#d62728"
PANEL_TITLES = ("allowable cutter", "standard cutter", "findings on the part", "B along the path")
AXES = "XYZ"


def png_base64(rgba: np.ndarray) -> str:
    """A (H, W, 4) uint8 image as base64 PNG text."""
    buf = io.BytesIO()
    Image.fromarray(rgba[:, :, :3]).save(buf, format="png", compress_level=1)
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


class JobPainter:
    """Draws the four pictures of a job; one instance per process, reused for every job."""

    def __init__(self, standard_names: list[str], dpi: int = 72) -> None:
        w, h = PANEL_PX
        self.fig = Figure(figsize=(4 * w / dpi, h / dpi), dpi=dpi)
        FigureCanvasAgg(self.fig)
        self.standard_names = standard_names
        fw, top, bottom = 0.25, 0.86, 0.12
        rect = [(k * fw + 0.012, bottom, 0.16, top - bottom) for k in range(4)]
        rect[3] = (3 * fw + 0.035, bottom + 0.06, 0.205, top - bottom - 0.06)
        self.axes = [self.fig.add_axes(r) for r in rect]
        for ax in self.axes[:3]:
            ax.set_xticks([])
            ax.set_yticks([])
        a_map, s_map, f_map, b_ax = self.axes
        self.allow = a_map.scatter([], [], c=[], s=6, linewidths=0, cmap="viridis",
                                   norm=LogNorm(*ALLOWABLE_RANGE))
        cax = self.fig.add_axes((0.012 + 0.165, bottom, 0.008, top - bottom))
        self.fig.colorbar(self.allow, cax=cax).set_label("allowable size, mm", fontsize=8)
        cax.tick_params(labelsize=7)
        colours = [STANDARD_NONE, *matplotlib.colormaps["tab10"].colors[: len(standard_names)]]
        self.standard_cmap = ListedColormap(colours)
        self.std = s_map.scatter([], [], c=[], s=6, linewidths=0, cmap=self.standard_cmap,
                                 vmin=-1.5, vmax=len(standard_names) - 0.5)
        s_map.legend(
            handles=[Patch(color=c, label=n) for c, n in
                     zip(colours, ["none", *standard_names], strict=True)],
            loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False,
        )
        self.find = f_map.scatter([], [], s=4, linewidths=0)
        f_map.legend(
            handles=[Line2D([], [], ls="", marker="o", color=VERDICT_COLOURS[v], label=v)
                     for v in VERDICTS],
            loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False,
        )
        self.verdict_rgba = np.array(
            [matplotlib.colors.to_rgba(VERDICT_COLOURS[v]) for v in VERDICTS]
        )
        (self.line_a,) = b_ax.plot([], [], ".", ms=2, color="#1f77b4")
        (self.line_b,) = b_ax.plot([], [], "-", lw=1.2, color="#ff7f0e")
        self.limit = b_ax.axhline(0.0, color="#d62728", lw=1.0, ls="--")
        self.b_legend = b_ax.legend(
            [self.line_a, self.line_b, self.limit], ["", "", ""], fontsize=7, loc="lower left",
            bbox_to_anchor=(0.0, 1.0), ncol=3, frameon=False, handlelength=1.2,
            columnspacing=0.8,
        )
        b_ax.xaxis.set_major_locator(MaxNLocator(4))
        b_ax.yaxis.set_major_locator(MaxNLocator(5))
        b_ax.tick_params(labelsize=7)
        b_ax.set_xlabel("path length, mm", fontsize=8)
        self.titles = [
            self.fig.text(k * fw + 0.01, 0.93, "", fontsize=9, weight="bold") for k in range(4)
        ]

    def render(
        self, arrays: dict[str, np.ndarray], standard: StandardCutters, cutter_size: float | None
    ) -> list[str]:
        """The four pictures (base64 PNG) of one job from its point arrays (see
        `checker.store.point_arrays`)."""
        cc, allowable, verdict = arrays["cc"], arrays["allowable"], arrays["verdict"]
        i, j = _projection(cc)
        xy = cc[:, [i, j]]
        a_map, s_map, f_map, b_ax = self.axes
        lo, hi = (xy.min(axis=0), xy.max(axis=0)) if len(xy) else (np.zeros(2), np.ones(2))
        pad = 0.03 * max(float(np.max(hi - lo)), 1e-6)
        view = f"{AXES[i]}{AXES[j]} view, {hi[0] - lo[0]:.0f} x {hi[1] - lo[1]:.0f} mm"
        for ax in self.axes[:3]:
            ax.set_xlim(lo[0] - pad, hi[0] + pad)
            ax.set_ylim(lo[1] - pad, hi[1] + pad)
            ax.set_aspect("equal", adjustable="box")
            ax.set_xlabel(view, fontsize=7)
        shown = np.where(np.isnan(allowable), ALLOWABLE_RANGE[1], allowable)
        self.allow.set_offsets(xy)
        self.allow.set_array(np.clip(shown, *ALLOWABLE_RANGE))
        self.std.set_offsets(xy)
        self.std.set_array(standard.largest(allowable).astype(float))
        order = np.argsort(verdict != 0, kind="stable")  # findings drawn last, on top
        self.find.set_offsets(xy[order])
        self.find.set_facecolors(self.verdict_rgba[verdict[order]])
        self.find.set_sizes(np.where(verdict[order] == 0, 3.0, 14.0))
        self._path_panel(arrays, cutter_size)
        n_find = int(np.sum(verdict != 0))
        texts = (
            f"{PANEL_TITLES[0]} (min {np.nanmin(allowable, initial=np.inf):.3g} mm)",
            PANEL_TITLES[1],
            f"{PANEL_TITLES[2]} ({n_find})",
            self._path_title,
        )
        for t, s in zip(self.titles, texts, strict=True):
            t.set_text(s)
        self.fig.canvas.draw()
        img = np.asarray(self.fig.canvas.buffer_rgba())
        w = img.shape[1] // 4
        return [png_base64(img[:, k * w : (k + 1) * w]) for k in range(4)]

    def _path_panel(self, arrays: dict[str, np.ndarray], cutter_size: float | None) -> None:
        cc_only = arrays["kind"]
        s = path_length(arrays["cc"][cc_only])
        b_best, b_chosen = arrays["b_best"][cc_only], arrays["b_chosen"][cc_only]
        ax = self.axes[3]
        texts = self.b_legend.get_texts()
        if np.isfinite(b_chosen).any() or np.isfinite(b_best).any():
            self._path_title = "B chosen vs best B"
            self.line_a.set_data(s, b_best)
            self.line_b.set_data(s, b_chosen)
            self.limit.set_visible(False)
            labels = ("best B", "chosen B", "")
            ax.set_ylabel("B, degrees", fontsize=8)
            values = np.concatenate([b_best, b_chosen])
        else:
            self._path_title = "allowable along the path (no B)"
            allowable = arrays["allowable"][cc_only]
            self.line_a.set_data(s, allowable)
            self.line_b.set_data([], [])
            self.limit.set_visible(cutter_size is not None)
            self.limit.set_ydata([cutter_size or 0.0] * 2)
            labels = ("allowable", "", "real size")
            ax.set_ylabel("size, mm", fontsize=8)
            values = np.concatenate([np.clip(allowable, 0, ALLOWABLE_RANGE[1]),
                                     [cutter_size or 0.0]])
        for t, label in zip(texts, labels, strict=True):
            t.set_text(label)
        finite = values[np.isfinite(values)]
        lo, hi = (finite.min(), finite.max()) if len(finite) else (0.0, 1.0)
        margin = 0.05 * max(hi - lo, 1.0)
        ax.set_ylim(lo - margin, hi + margin)
        ax.set_xlim(0.0, max(float(s[-1]) if len(s) else 1.0, 1e-6))


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
