"""The standard tool library: the shipped file validates, lookups pick the largest cutter not
exceeding a size, and bad entries are rejected with the tool and field named."""

from __future__ import annotations

import math

import numpy as np
import pytest

from checker.errors import PathcheckError
from checker.tool_library import largest_fitting, load_tool_library


@pytest.fixture(scope="module")
def lib():
    return load_tool_library()


def test_shipped_library(lib):
    names = {t.name for t in lib.tools}
    for n in (
        "FLAT-D10",
        "BALL-D10",
        "BULL-D12-R2",
        "FLAT-1/2IN",
        "BALL-1/4IN",
        "BULL-1/2IN-R1/16IN",
    ):
        assert n in names
    assert {t.kind for t in lib.tools} >= {"flat", "ball", "bullnose"}
    assert all(t.flute_length and 0 < t.flute_length <= t.H for t in lib.tools)
    assert any(t.holder_diameter for t in lib.tools) and any(t.shank_diameter for t in lib.tools)
    half = lib["FLAT-1/2IN"]
    assert (half.kind, half.d, half.R, half.r) == ("flat", 12.7, 6.35, 0.0)
    bull = lib["BULL-1/2IN-R1/16IN"]
    assert (bull.r, bull.R) == pytest.approx((25.4 / 16, 6.35 - 25.4 / 16))
    assert lib["BALL-D10"].size == 5.0 and lib["BULL-D12-R2"].size == 4.0
    tb = lib["TBALL-R2.5-T5"]
    assert tb.kind == "tapered_ball" and tb.r == 2.5 and tb.theta == pytest.approx(math.radians(5))


def test_largest_not_exceeding_matches_brute_force(lib):
    rng = np.random.default_rng(0)
    for fam, r in (("flat", None), ("ball", None), ("bullnose", 2.0), ("bullnose", None)):
        cands = [t for t in lib.tools if t.kind == fam and (r is None or t.r == r)]
        sizes = rng.uniform(0, 16, 200)
        sizes[:3] = [0.0, cands[0].size, np.inf]
        fam_sorted = lib.family(fam, r)
        idx = largest_fitting([t.size for t in fam_sorted], sizes)
        for s, i in zip(sizes, idx, strict=True):
            fit = [t.size for t in cands if t.size <= s]
            got = lib.largest_not_exceeding(fam, s, r)
            if not fit:
                assert got is None and i == -1
            else:
                assert got.size == max(fit) and fam_sorted[i].size == max(fit)
    assert lib.largest_not_exceeding("ball", 3.3).name == "BALL-1/4IN"  # r 3.175 > 3.0 (D6)
    assert lib.largest_not_exceeding("ball", 0.1) is None
    assert lib.largest_not_exceeding("bullnose", 4.0, r=2.0).name == "BULL-D12-R2"
    balls = [t.size for t in lib.family("ball")]
    assert list(largest_fitting(balls, [np.nan, np.inf, balls[1] * (1 - 1e-13)])) == [
        -1, len(balls) - 1, 1]  # no answer, unbounded, equal to the last digits
    assert list(largest_fitting([], [1.0, np.inf])) == [-1, -1]
    t3 = lib.largest_not_exceeding("tapered_ball", 2.0, theta=math.radians(3))
    assert t3.name == "TBALL-R1.5-T3"
    assert lib.largest_not_exceeding("tapered_ball", 2.0, theta=math.radians(5)) is None


def _write(tmp_path, body: str):
    p = tmp_path / "tools.toml"
    p.write_text(body)
    return p


@pytest.mark.parametrize(
    ("body", "pattern"),
    [
        (
            '[[tool]]\nname="B"\nkind="bullnose"\nd=10\nr=6\nflute_length=20\n',
            r"tool 'B': corner radius r=6 is larger than half the diameter d=10",
        ),
        (
            '[[tool]]\nname="F"\nkind="flat"\nd=10\n',
            r"tool 'F' field 'flute_length': Field required",
        ),
        (
            '[[tool]]\nname="F"\nkind="flat"\nd=-1\nflute_length=3\n',
            r"tool 'F' field 'd': .*greater than 0, found -1",
        ),
        ('[[tool]]\nname="F"\nkind="drill"\nd=3\nflute_length=3\n',
         r"tool 'F' field 'kind': .*found 'drill'"),
        ('[[tool]]\nname="F"\nkind="flat"\nd=3\nflute_length=3\ncolour="red"\n',
         r"field 'colour': Extra inputs are not permitted, found 'red'"),
        ('[[tool]]\nname="F"\nkind="flat"\nd=3\nr=1\nflute_length=3\n', r"flat end-mill has r = 0"),
        ('[[tool]]\nname="F"\nkind="ball"\nd=3\nr=1\nflute_length=3\n', r"d=3 disagrees with r=1"),
        ('[[tool]]\nname="F"\nkind="flat"\nd=3\nflute_length=3\n' * 2, r"'F' is defined twice"),
        ('[[tool]\nname="F"\n', r"not valid TOML"),
        ("[holder]\nd=3\n", r"expected only \[\[tool\]\] tables, found holder"),
        ("", r"expected at least one \[\[tool\]\] table"),
    ],
)
def test_bad_library_names_tool_and_field(tmp_path, body, pattern):
    with pytest.raises(PathcheckError, match=pattern) as err:
        load_tool_library(_write(tmp_path, body))
    assert err.value.code == "tools" and str(err.value).startswith(str(tmp_path))


def test_missing_file_and_unknown_tool(tmp_path, lib):
    with pytest.raises(PathcheckError, match="tool library not found"):
        load_tool_library(tmp_path / "none.toml")
    with pytest.raises(PathcheckError, match="no tool named 'X'"):
        lib["X"]


def test_inch_units_convert_every_length(tmp_path):
    p = _write(
        tmp_path,
        '[[tool]]\nname="T"\nkind="bullnose"\nunits="inch"\nd=1\nr=0.125\nflute_length=2\n'
        "length=3\nshank_diameter=1\nholder_diameter=2\nholder_length=3\nstickout=4\n",
    )
    t = load_tool_library(p)["T"]
    assert (t.d, t.r, t.R, t.flute_length, t.H) == pytest.approx((25.4, 3.175, 9.525, 50.8, 76.2))
    assert (t.shank_diameter, t.holder_diameter, t.holder_length, t.stickout) == pytest.approx(
        (25.4, 50.8, 76.2, 101.6)
    )
