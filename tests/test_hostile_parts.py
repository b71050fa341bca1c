"""The hostile part files of issue #18, each as a real `pathcheck` run with its expected one-line
error (exit 2), or, for valid but extreme parts, a real result within the time and memory
bounds; and the reader sandbox's own limits (a crash, the time limit, the memory limit)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
from part_runs import problems, run_pathcheck

from checker.config import GeometryConfig
from checker.errors import PathcheckError
from checker.geometry import load_part, reader_limits
from checker.sandbox import Limits, run_contained

REPO = Path(__file__).resolve().parents[1]
MOULD = json.loads((REPO / "samples" / "mould" / "mould.json").read_text())


def _mould(tmp_path: Path, name: str, change) -> Path:
    """The sample mould with `change(surface 0)` applied, written to tmp_path/name."""
    doc = copy.deepcopy(MOULD)
    change(doc["shape"]["data"][0])
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def _one_line_error(path: Path, *args: str) -> str:
    """The message of `pathcheck info PATH` (or ARGS), which must fail cleanly with exit 2."""
    run = run_pathcheck(list(args) or ["info", str(path)])
    assert problems(run, path) == []
    assert run.rc == 2, run.stdout[-300:]
    return run.stderr.strip()


def _set(key, value):
    return lambda s: s.__setitem__(key, value)


def _weights(s, w):
    s["control_points"]["weights"] = w


def _circle(n: int) -> list[list[float]]:
    t = np.linspace(0.0, 2 * np.pi, n)
    return np.column_stack([0.5 + 0.3 * np.cos(t), 0.5 + 0.3 * np.sin(t)]).tolist()


def _spline_trim(degree: int, points: list) -> dict:
    n = len(points)
    inner = np.linspace(0, 1, n - degree + 1)[1:-1].tolist()
    knots = [0.0] * (degree + 1) + inner + [1.0] * (degree + 1)
    return {"data": [{"type": "spline", "degree": degree, "knotvector": knots,
                      "control_points": {"points": points}, "reversed": 1}]}


@pytest.mark.parametrize(("name", "change", "expect"), [
    ("degree_inf.json", _set("degree_u", float("inf")),
     "surface 0: degree_u: degree inf out of range, expected 1..25"),
    ("degree_str.json", _set("degree_v", "3"),
     "surface 0: degree_v: expected an integer degree, found '3'"),
    ("trim_null.json", _set("trims", {"data": [None]}),
     "surface 0: trims.data[0]: expected a trim curve object, found NoneType"),
    ("trim_deg40.json", _set("trims", _spline_trim(40, _circle(41))),
     "surface 0: trims.data[0].degree 40 out of range, expected 1..25"),
    ("weights_tiny.json", lambda s: _weights(s, [1e-300] + [1.0] * 29),
     "surface 0: weights: weights range from 1e-300 to 1, more than a factor 1e+08"),
    ("weights_neg.json", lambda s: _weights(s, [-1.0] + [1.0] * 29),
     "surface 0: weights: weights must be positive and finite"),
    ("coord_huge.json", lambda s: s["control_points"]["points"][3].__setitem__(2, 1e308),
     "surface 0: control_points: coordinate 1e+308 mm beyond the range +-1e+06 mm"),
    ("coord_nan.json", lambda s: s["control_points"]["points"][0].__setitem__(0, float("nan")),
     "surface 0: control_points: non-finite coordinate (nan or inf)"),
    ("knots_down.json", lambda s: s["knotvector_u"].__setitem__(4, 0.9),
     "surface 0: knotvector_u: knot vector is not non-decreasing"),
    ("size_huge.json", _set("size_u", 10**30), "surface 0: size_u 1000000000000000000000000000000 "
     "out of range, expected 1..30"),
])
def test_geomdl_values_out_of_range_are_one_line(tmp_path, name, change, expect):
    path = _mould(tmp_path, name, change)
    assert _one_line_error(path) == f"pathcheck: {path}: {expect}"


def test_deep_nesting_is_one_line(tmp_path):
    """100,000 nested lists: JSON stops at the parser's recursion limit, YAML at 64 levels
    (PyYAML's C composer would crash: the pure-Python one is used, bounded)."""
    deep = tmp_path / "deep.json"
    deep.write_text('{"shape": ' + "[" * 100_000 + "]" * 100_000 + "}")
    assert _one_line_error(deep) == f"pathcheck: {deep}: nested too deeply"
    ydeep = tmp_path / "deep.yaml"
    ydeep.write_text("shape: " + "[" * 100_000 + "]" * 100_000 + "\n")
    assert _one_line_error(ydeep) == f"pathcheck: {ydeep}: nested deeper than 64 levels"


def test_yaml_alias_bomb_is_one_line(tmp_path):
    """A 1 KB document whose aliases expand to 10^10 values is refused while it is composed."""
    lines = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, 10)]
    lines.append("shape: {type: surface, data: [{degree_u: 1, degree_v: 1, size_u: 2, "
                 "size_v: 2, knotvector_u: [0, 0, 1, 1], knotvector_v: [0, 0, 1, 1], "
                 "control_points: {points: *a9}}]}")
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("\n".join(lines) + "\n")
    assert len(bomb.read_bytes()) < 1024
    limit = 4 * len(bomb.read_text()) + 100_000  # values: 4 per character + 100,000
    assert _one_line_error(bomb) == (
        f"pathcheck: {bomb}: YAML aliases expand to more than {limit} values")


def test_recursive_yaml_alias_is_one_line(tmp_path):
    path = tmp_path / "loop.yaml"
    path.write_text("shape: &s {type: surface, data: [*s]}\n")
    assert _one_line_error(path) == (
        f"pathcheck: {path}: recursive YAML alias (an anchor used inside itself)")


def test_300k_point_trim_loop_maps_within_bounds(tmp_path):
    """A 300,000-point trim loop is a valid part: `map --grid 3x3` (test points, trims, the
    engine) answers with memory in O(points) (it passed 4 GB before)."""
    trims = {"data": [{"type": "freeform", "points": _circle(300_000), "reversed": 1}]}
    path = _mould(tmp_path, "trim300k.json", _set("trims", trims))
    run = run_pathcheck(["map", "--part", str(path), "--cutter", "CUTTER/10,5", "--grid", "3x3",
                         "-o", str(tmp_path / "map")])
    assert problems(run, path) == [] and run.rc == 0, run.stderr[-400:]
    assert run.max_rss_mb < 1500
    doc = json.loads((tmp_path / "map" / "map.json").read_text())
    assert len(doc["surfaces"]) == 8


def test_300k_pole_trim_spline_is_sampled_within_bounds(tmp_path):
    """A degree-3 trim spline with 300,000 poles: sampled with fewer points per span (at most
    1,000,000 in all, not 32 per span), so `info` stays small."""
    path = _mould(tmp_path, "spline300k.json", _set("trims", _spline_trim(3, _circle(300_000))))
    run = run_pathcheck(["info", "--json", "-", str(path)])
    assert problems(run, path) == [] and run.rc == 0, run.stderr[-400:]
    assert run.max_rss_mb < 1000
    assert json.loads(run.stdout)["surfaces"][0]["trimmed"]


@pytest.mark.parametrize(("value", "expect"), [
    (3e38, "vertices: coordinate 3e+38 mm beyond the range +-1e+06 mm"),
    (1e15, "vertices: coordinate 1e+15 mm beyond the range +-1e+06 mm"),
])
def test_stl_with_one_moved_vertex_is_one_line(realdata, tmp_path, value, expect):
    """One vertex of a binary STL moved far away ("Unable to allocate 8.13 TiB", or exit 0 with
    a limiting point at z = 3e38, before)."""
    raw = bytearray((realdata / "amorim-solidworkscam-apt" / "Teste-Metrologia.STL").read_bytes())
    raw[104:108] = np.float32(value).tobytes()  # z of the first vertex of the first triangle
    path = tmp_path / "moved.stl"
    path.write_bytes(bytes(raw))
    apt = realdata / "amorim-solidworkscam-apt" / "Teste-Metrologia.apt"
    assert _one_line_error(path, str(apt), "--part", str(path)) == f"pathcheck: {path}: {expect}"


def test_ascii_stl_number_beyond_float32_is_one_line(realdata, tmp_path):
    """An ASCII STL vertex of 1e308 overflows numpy-stl's float32 (its RuntimeWarning made a
    second line on stderr; found by the nightly fuzz)."""
    from stl import Mode
    from stl import mesh as stl_mesh

    path = tmp_path / "big.stl"
    stl_mesh.Mesh.from_file(str(realdata / "amorim-solidworkscam-apt" / "Teste-Metrologia.STL")
                            ).save(str(path), mode=Mode.ASCII)
    text = path.read_bytes()
    at = text.index(b"vertex") + len(b"vertex ")
    path.write_bytes(text[:at] + b"1e308" + text[text.index(b" ", at):])
    assert _one_line_error(path) == (
        f"pathcheck: {path}: STL file holds no triangles or non-finite coordinates (or beyond "
        "float32's 3.4e38)")


def _without_line(raw: bytes, index: int) -> bytes:
    lines = raw.split(b"\n")
    return b"\n".join(lines[:index] + lines[index + 1 :])


def _with_byte(raw: bytes, at: int, byte: int) -> bytes:
    return raw[:at] + bytes([byte]) + raw[at:]


@pytest.mark.parametrize(("name", "damage", "kind"), [
    ("ec_turbine-A.stp", lambda raw: _without_line(raw, 19376), "STEP"),
    ("PRO20359-L2.igs", lambda raw: _with_byte(raw, 2245, 0xAA), "IGES"),
])
def test_damaged_cad_file_that_crashes_opencascade_is_one_line(realdata, tmp_path, name,
                                                               damage, kind):
    """ec_turbine-A.stp without its line 19,377, PRO20359-L2.igs with one byte inserted: each
    makes OpenCASCADE segfault (exit 139 before, found by `tests/test_fuzz_parts.py`'s
    mutations); the reader runs in a child process, so the run ends with one line, exit 2."""
    path = tmp_path / f"damaged-{name}"
    path.write_bytes(damage((realdata / "occt-cad-nurbs" / name).read_bytes()))
    assert _one_line_error(path) == (
        f"pathcheck: {path}: the {kind} reader (OpenCASCADE) crashed on this file (SIGSEGV): "
        "the file is damaged or not supported")


def test_sandbox_crash_time_and_memory_limits(realdata):
    """A child that aborts, a read longer than the time limit, a read larger than the memory
    limit: each is one PathcheckError naming the file; the parent lives on."""
    with pytest.raises(PathcheckError) as err:
        run_contained("os:abort", [], Limits(seconds=30, memory_mb=1024), "x.step", "the reader")
    assert str(err.value) == ("x.step: the reader crashed on this file (SIGABRT): the file is "
                              "damaged or not supported")
    hammer = realdata / "occt-cad-nurbs" / "hammer.iges"  # 1 s to read alone
    fast = GeometryConfig(reader_time_s=0.3, reader_time_s_per_mb=1e-9)
    with pytest.raises(PathcheckError, match=r"hammer.iges: the IGES reader \(OpenCASCADE\) "
                       r"stopped after 0.3 s \(the time limit"):
        load_part(hammer, geometry=fast)
    small = GeometryConfig(reader_memory_mb=150)
    # OpenCASCADE meets the failed allocation either with std::bad_alloc (the memory limit
    # named) or by dereferencing the null it got (a crash): one line naming the file either way
    with pytest.raises(PathcheckError, match=r"hammer.iges: the IGES reader \(OpenCASCADE\) "
                       r"(needed more than 150 MB \(the memory limit|crashed on this file)"):
        load_part(hammer, geometry=small)
    assert len(load_part(hammer).surfaces) > 0


def test_reader_time_limit_grows_with_the_file():
    cfg = GeometryConfig()
    assert reader_limits(cfg, 0) == Limits(seconds=20.0, memory_mb=2048)
    assert reader_limits(cfg, 3 * 2**20) == Limits(seconds=80.0, memory_mb=2048)


def test_cad_trim_point_beyond_range_is_one_line(realdata, tmp_path):
    """A CARTESIAN_POINT coordinate of ec_turbine-A.stp at byte 1,055,243 made 1e999 (the
    nightly fuzz's case 358): the trim index printed numpy's cast warning before the error;
    now the error alone."""
    raw = (realdata / "occt-cad-nurbs" / "ec_turbine-A.stp").read_bytes()
    at = 1055243
    end = raw.index(b",", at)
    path = tmp_path / "far.stp"
    path.write_bytes(raw[:at] + b"1e999" + raw[end:])
    assert _one_line_error(path) == (
        f"pathcheck: {path}: surface 36 (face_36_cone): trims: trim points must be finite and "
        "within +-1e+09")
