"""The deviation file (checker/machined/output.py): PLY read back by trimesh (an independent
reader), binary legacy VTK read back by a plain parser here, the PNG map, THICK read as the stock to
leave, and the `--deviation-out`/`--leave` usage errors (one line, exit 2, before any work)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from checker.apt.read import read_cl_text
from checker.machined.leave import operation_leave
from checker.machined.output import write_deviation
from checker.machined.points import surface_mesh

ROOT = Path(__file__).resolve().parents[1]


def _mesh_and_values():
    V = np.array([[0, 0, 0], [10, 0, 0], [10, 6, 2], [0, 6, 2]], float)
    mesh = surface_mesh(V, np.array([[0, 1, 2], [0, 2, 3]]), np.full(2, -1), 0.7)
    dev = 0.3 * np.sin(mesh.vertices[:, 0]) * np.cos(mesh.vertices[:, 1])
    dev[::17] = np.nan                       # points the stock never covered
    return mesh, dev


def _read_vtk(path: Path):
    """Binary legacy VTK polydata: points, polygons, the point scalars (big-endian)."""
    raw = path.read_bytes()

    def after(header: bytes) -> int:
        start = raw.index(header)
        return raw.index(b"\n", start) + 1

    words = raw[raw.index(b"POINTS"):].split(b"\n", 1)[0].split()
    n = int(words[1])
    at = after(b"POINTS")
    pts = np.frombuffer(raw, ">f8", 3 * n, at).reshape(n, 3)
    m = int(raw[raw.index(b"POLYGONS"):].split(b"\n", 1)[0].split()[1])
    faces = np.frombuffer(raw, ">i4", 4 * m, after(b"POLYGONS")).reshape(m, 4)
    vals = np.frombuffer(raw, ">f8", n, after(b"LOOKUP_TABLE"))
    return pts, faces, vals


def test_ply_and_vtk_hold_the_mesh_and_its_deviation(tmp_path):
    mesh, dev = _mesh_and_values()
    ply, png = write_deviation(tmp_path / "d.ply", mesh, dev)
    got = trimesh.load(ply, process=False)
    assert len(got.vertices) == len(mesh.vertices) and len(got.faces) == len(mesh.triangles)
    assert np.allclose(got.vertices, mesh.vertices, atol=1e-5)
    assert np.array_equal(got.faces, mesh.triangles)
    d = np.asarray(got.metadata["_ply_raw"]["vertex"]["data"]["deviation"], float)
    assert np.array_equal(np.isnan(d), np.isnan(dev))
    assert np.allclose(d[~np.isnan(d)], dev[~np.isnan(dev)], atol=1e-7)
    assert png == tmp_path / "d.png" and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    vtk, _ = write_deviation(tmp_path / "d.vtk", mesh, dev)
    pts, faces, vals = _read_vtk(vtk)
    assert np.allclose(pts, mesh.vertices, atol=1e-7) and np.all(faces[:, 0] == 3)
    assert np.array_equal(faces[:, 1:], mesh.triangles)
    assert np.array_equal(np.isnan(vals), np.isnan(dev))
    assert np.allclose(vals[~np.isnan(vals)], dev[~np.isnan(dev)], atol=1e-8)


def test_measuring_mesh_edges_and_normals():
    mesh, _ = _mesh_and_values()
    V, T = mesh.vertices, mesh.triangles
    edges = np.concatenate([V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 1]],
                            V[T[:, 0]] - V[T[:, 2]]])
    assert np.linalg.norm(edges, axis=1).max() <= 0.7 + 1e-12
    want = np.array([0.0, -2.0, 6.0]) / np.hypot(2.0, 6.0)        # the plane's normal
    assert np.allclose(mesh.normals, want, atol=1e-9)
    assert mesh.area.sum() == pytest.approx(10.0 * np.hypot(6.0, 2.0), rel=1e-9)


def test_thick_is_the_stock_left_per_operation():
    text = ("PARTNO/T\nUNITS/INCHES\nCUTTER/0.25\nTHICK/0.01\nFEDRAT/10\nGOTO/0,0,1\n"
            "GOTO/1,0,1\nLOADTL/2\nTHICK/0\nGOTO/0,1,1\nGOTO/1,1,1\nFINI\n")
    tp = read_cl_text(text, "t.apt")
    assert len(tp.operations) == 2
    assert np.allclose(operation_leave(tp), [0.254, 0.0])
    assert np.allclose(operation_leave(tp, 0.1), [0.254, 0.1])


@pytest.mark.parametrize("args, expected", [
    (["--stock", "box:+2", "--deviation-out", "d.txt"], "expected a .ply or .vtk file"),
    (["--deviation-out", "d.ply"], "expected --stock too"),
    (["--stock", "box:+2", "--leave", "-1"], "--leave -1: expected a thickness"),
])
def test_bad_deviation_options_are_one_usage_line(tmp_path, args, expected):
    run = subprocess.run([sys.executable, "-m", "checker.cli", str(ROOT / "samples" / "mould" /
                                                                  "mould.apt"), *args,
                          "--no-store"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 2, run.stderr
    assert expected in run.stderr and len(run.stderr.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_deviation_out_without_a_part_is_a_usage_error(tmp_path):
    from checker.check import check_job
    from checker.check.options import CheckOptions
    from checker.errors import PathcheckError
    from checker.stock.request import StockRequest

    job = tmp_path / "alone.apt"
    job.write_text("PARTNO/A\nCUTTER/6\nFEDRAT/100\nGOTO/0,0,5\nGOTO/10,0,5\nFINI\n")
    request = StockRequest("box:-5,-5,0,15,5,6", deviation_out=tmp_path / "d.ply")
    with pytest.raises(PathcheckError, match="expected a part") as err:
        check_job(job, options=CheckOptions(stock=request))
    assert err.value.code == "usage" and not (tmp_path / "d.ply").exists()
