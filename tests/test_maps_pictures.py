"""The `pathcheck map` pictures: their colour scale (log where the sizes span decades, as the
report's), unbounded sizes in their own colour rather than as a large value, and a real dpi."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import LogNorm, to_rgb
from PIL import Image

from checker.cutter import parse_cutter
from checker.engine.maps import SurfaceMap
from checker.report.pictures import MAP_DPI, UNBOUNDED, draw_maps, size_norm, standard_colours
from checker.tool_library import load_tool_library


def test_size_norm_is_log_over_decades_and_ignores_unbounded_and_zero():
    wide = size_norm(np.array([0.5, 3.0, 60.0, np.inf, 0.0, np.nan]))
    assert isinstance(wide, LogNorm) and (wide.vmin, wide.vmax) == (0.5, 60.0)
    narrow = size_norm(np.array([15.6, 61.0, np.inf]))
    assert not isinstance(narrow, LogNorm) and (narrow.vmin, narrow.vmax) == (15.6, 61.0)


def _surface(sid: int, size: np.ndarray) -> SurfaceMap:
    nu, nv = size.shape
    u, v = np.linspace(0, 1, nu), np.linspace(0, 1, nv)
    U, V = np.meshgrid(u, v, indexing="ij")
    cc = np.stack([U * 50 + 60 * sid, V * 50, np.zeros_like(U)], axis=-1)
    normal = np.zeros_like(cc)
    normal[..., 2] = 1.0
    return SurfaceMap(sid, f"s{sid}", u, v, np.ones(size.shape, bool), cc, normal, size,
                      np.zeros(size.shape, int))


def _unbounded_share(path) -> float:
    img = np.asarray(Image.open(path).convert("RGB")).astype(int)
    pink = np.round(255 * np.array(to_rgb(UNBOUNDED))).astype(int)
    return float(np.all(np.abs(img - pink) <= 2, axis=2).mean())


def test_unbounded_is_its_own_colour(tmp_path):
    cutter = parse_cutter("CUTTER/10,5")
    tools = load_tool_library().family("ball", None)
    finite = np.geomspace(0.5, 80.0, 100).reshape(10, 10)
    files = draw_maps([_surface(0, finite), _surface(1, np.full((10, 10), np.inf))], cutter,
                      tools, tmp_path / "a", "bowl.json")
    with Image.open(files[0]) as img:
        assert np.allclose(img.info["dpi"], (MAP_DPI, MAP_DPI), atol=0.1)
    # the unbounded surface fills a panel in the marked colour; drawn finite, only the legend's
    # patch has it
    control = draw_maps([_surface(0, finite), _surface(1, finite * 2)], cutter, tools,
                        tmp_path / "b", "bowl.json")
    assert _unbounded_share(files[0]) > 0.08
    assert 0 < _unbounded_share(control[0]) < 0.005


def test_standard_map_has_the_reports_colours(tmp_path):
    """The standard map of `pathcheck map` paints a cutter in the colour the report gives it
    (`standard_colours`): on a part where the third tool fits everywhere the points are that
    colour; every other colour is only a legend patch."""
    cutter = parse_cutter("CUTTER/10,5")
    tools = load_tool_library().family("ball", None)
    surfaces = [_surface(k, np.full((12, 12), 5.0)) for k in range(2)]
    for s in surfaces:
        s.standard[:] = 2
    files = draw_maps(surfaces, cutter, tools, tmp_path, "bowl.json")
    img = np.asarray(Image.open(files[1]).convert("RGB")).astype(int)
    colours = standard_colours(len(tools))[:, :3].astype(int)

    def share(k: int) -> float:
        return float(np.all(np.abs(img - colours[k + 1]) <= 2, axis=2).mean())

    others = [share(k) for k in range(-1, len(tools)) if k != 2]
    assert share(2) > 10 * max(others) and min(others) > 0
