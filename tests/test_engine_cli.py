"""`pathcheck allowable` and `pathcheck map` through the real console entry point: JSON keys,
timing, numbers against the closed form (a ball in a concave spherical bowl: r* = rho), PNG
pictures, and bad input as one line with exit code 2."""

from __future__ import annotations

import contextlib
import io
import json
import subprocess

import numpy as np
import pytest
from engine_parts import bowl
from geomdl import exchange

from checker.cli import main
from checker.geometry.evaluate import evaluate

RHO = 20.0


def _cli(*args: str) -> subprocess.CompletedProcess:
    """Run the console entry point in this process (as `pathcheck ARGS`)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main(list(args))
            code = 0
        except SystemExit as exc:
            code = int(exc.code or 0)
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


@pytest.fixture(scope="module")
def bowl_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bowl")
    part, g = bowl(RHO)
    exchange.export_json(g, str(d / "bowl.json"))
    doc = json.loads((d / "bowl.json").read_text())
    doc["shape"]["data"][0]["reversed"] = int(part.surfaces[0].flip)  # normal towards the tool
    (d / "bowl.json").write_text(json.dumps(doc))
    u, v = np.array([0.1, 0.4, 0.7]), np.array([0.3, 0.5, 0.6])
    ev = evaluate(part.surfaces[0], u, v)
    rows = ["x,y,z,nx,ny,nz"] + [",".join(f"{t:.9f}" for t in (*p, *n))
                                  for p, n in zip(ev.points, ev.normals, strict=True)]
    (d / "cc.csv").write_text("\n".join(rows) + "\n")
    return d


def test_allowable_json(bowl_files, tmp_path):
    out = tmp_path / "a.json"
    run = _cli("allowable", "--part", str(bowl_files / "bowl.json"), "--cc",
               str(bowl_files / "cc.csv"), "--cutter", "CUTTER/30,15", "--json", str(out))
    assert run.returncode == 0, run.stderr
    doc = json.loads(out.read_text())
    assert set(doc["timing"]) == {"load_s", "sample_s", "search_s"}
    assert len(doc["points"]) == 3
    for p in doc["points"]:
        assert set(p) >= {"index", "cc", "normal", "allowable", "limiting_point",
                          "limiting_surface", "advice"}
        assert abs(p["allowable"] - RHO) < 1e-4
        assert p["advice"] == "fits" and p["limiting_surface"] == 0
    assert "allowable r" in run.stdout


def test_allowable_pso_method(bowl_files, tmp_path):
    out = tmp_path / "p.json"
    run = _cli("allowable", "--part", str(bowl_files / "bowl.json"), "--cc",
               str(bowl_files / "cc.csv"), "--cutter", "CUTTER/50,25", "--method", "pso",
               "--seed", "3", "--json", str(out))
    assert run.returncode == 0, run.stderr
    doc = json.loads(out.read_text())
    assert doc["method"] == "pso"
    assert all(abs(p["allowable"] - RHO) < 1e-3 and p["advice"] == "too_large_near"
               for p in doc["points"])


def test_map_pictures_and_json(bowl_files, tmp_path):
    run = _cli("map", "--part", str(bowl_files / "bowl.json"), "--cutter", "CUTTER/10,5",
               "--grid", "6x5", "-o", str(tmp_path / "m"))
    assert run.returncode == 0, run.stderr
    for name in ("allowable_map.png", "standard_map.png"):
        assert (tmp_path / "m" / name).read_bytes()[:4] == b"\x89PNG"
    doc = json.loads((tmp_path / "m" / "map.json").read_text())
    pts = doc["surfaces"][0]["points"]
    assert len(pts) == 30
    inner = [p for p in pts if 0.05 < p["v"] < 0.95]  # below the rim (vertical normal there)
    assert all(abs(p["allowable"] - RHO) < 1e-3 for p in inner)
    assert {p["standard"] for p in inner} == {"BALL-1IN"}  # r 12.7 <= 20 < the next size
    rim = [p for p in pts if p["v"] == 1.0]
    assert all(p["allowable"] == 0.0 and p["standard"] is None for p in rim)


@pytest.mark.parametrize("args, text", [
    (["--cutter", "CUTTER/10,5"], "cc.csv"),
    (["--cutter", "CUTTER/10,20"], "CUTTER"),
    (["--cutter", "CUTTER/10,5", "--axis", "0,0"], "--axis"),
])
def test_allowable_bad_input(bowl_files, tmp_path, args, text):
    bad = tmp_path / "cc.csv"
    body = "1,2,3,0,0" if text == "cc.csv" else "0,0,0,0,0,1"
    bad.write_text(f"x,y,z,nx,ny,nz\n{body}\n")
    run = _cli("allowable", "--part", str(bowl_files / "bowl.json"), "--cc", str(bad), *args)
    assert run.returncode == 2
    assert "Traceback" not in run.stderr and text in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_cc_points_off_the_part(bowl_files, tmp_path):
    """A CC point that lies on no surface (the contact pairs are empty: once an IndexError,
    exit 3): a ball resting on the axis d mm above the bottom of the bowl (the lower hemisphere
    of radius RHO about (0, 0, RHO)), normal +z, has its centre at height d + r; it grows until
    it reaches the rim, the circle of radius RHO at height RHO: RHO^2 + (d + r - RHO)^2 = r^2,
    allowable r = (RHO^2 + (RHO - d)^2) / (2 (RHO - d)) (before that the hemisphere below the
    rim stays outside it)."""
    d = np.array([2.0, 6.0])
    cc = tmp_path / "off.csv"
    cc.write_text("x,y,z,nx,ny,nz\n" + "".join(f"0,0,{h},0,0,1\n" for h in d))
    out = tmp_path / "off.json"
    run = _cli("allowable", "--part", str(bowl_files / "bowl.json"), "--cc", str(cc),
               "--cutter", "CUTTER/30,15", "--json", str(out))
    assert run.returncode == 0, run.stderr
    got = [p["allowable"] for p in json.loads(out.read_text())["points"]]
    np.testing.assert_allclose(got, (RHO**2 + (RHO - d) ** 2) / (2 * (RHO - d)), atol=1e-4)
