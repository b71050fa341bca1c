"""load_part for geomdl JSON/YAML and STL, the part-beside-the-job rule and bad-file errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from geomdl import NURBS, exchange, multi

from checker.errors import PathcheckError
from checker.geometry import find_part_beside, load_part
from checker.geometry.evaluate import evaluate


def _geomdl_surface(rng, p, q, nu, nv, rational):
    s = NURBS.Surface()
    s.degree_u, s.degree_v = p, q
    s.ctrlpts_size_u, s.ctrlpts_size_v = nu, nv
    s.ctrlpts = rng.normal(scale=20.0, size=(nu * nv, 3)).tolist()
    if rational:
        s.weights = rng.uniform(0.5, 2.0, nu * nv).tolist()
    s.knotvector_u = np.r_[np.zeros(p), np.linspace(0, 1, nu - p + 1), np.ones(p)].tolist()
    s.knotvector_v = np.r_[np.zeros(q), np.linspace(0, 1, nv - q + 1), np.ones(q)].tolist()
    return s


@pytest.fixture(scope="module")
def container(tmp_path_factory):
    rng = np.random.default_rng(2)
    surfs = [_geomdl_surface(rng, 5, 5, 6, 6, True), _geomdl_surface(rng, 2, 3, 5, 7, False)]
    path = tmp_path_factory.mktemp("parts") / "two.json"
    exchange.export_json(multi.SurfaceContainer(*surfs), str(path))
    return path, surfs


def test_geomdl_container_loads_every_surface_exactly(container):
    path, surfs = container
    part = load_part(path)
    assert [s.id for s in part.surfaces] == [0, 1]
    assert [(s.degree_u, s.degree_v) for s in part.surfaces] == [(5, 5), (2, 3)]
    assert part.surfaces[0].rational and part.surfaces[0].ctrlpts.shape == (6, 6, 3)
    assert part.units == "mm" and len(part.content_hash) == 64
    rng = np.random.default_rng(0)
    for ours, g in zip(part.surfaces, surfs, strict=True):
        uv = rng.uniform(0, 1, (30, 2))
        want = np.array(g.evaluate_list(uv.tolist()))
        assert np.abs(evaluate(ours, uv[:, 0], uv[:, 1]).points - want).max() < 1e-10


def test_geomdl_yaml_gives_the_same_part(container, tmp_path):
    path, _ = container
    ypath = tmp_path / "two.yaml"
    ypath.write_text(yaml.safe_dump(json.loads(path.read_text())))
    a, b = load_part(path), load_part(ypath)
    for sa, sb in zip(a.surfaces, b.surfaces, strict=True):
        assert np.array_equal(sa.ctrlpts, sb.ctrlpts) and np.array_equal(sa.knots_u, sb.knots_u)


def test_load_is_cached_by_content(container):
    path, _ = container
    assert load_part(path) is load_part(path)


def test_ascii_stl_tetrahedron_normals_point_out(tmp_path):
    v = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], dtype=float)
    tris = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]  # outward winding
    lines = ["solid tet"]
    for t in tris:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += [f"vertex {x} {y} {z}" for x, y, z in v[list(t)]]
        lines += ["endloop", "endfacet"]
    path = tmp_path / "tet.stl"
    path.write_text("\n".join(lines + ["endsolid tet"]) + "\n")
    part = load_part(path)
    assert part.surfaces == [] and part.mesh.vertices.shape == (4, 3)
    centroid = v.mean(axis=0)
    tri_centres = part.mesh.vertices[part.mesh.triangles].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", part.mesh.normals, tri_centres - centroid) > 0)
    assert np.allclose(part.bbox, [[0, 0, 0], [10, 10, 10]])


def test_find_part_beside_prefers_step(tmp_path):
    job = tmp_path / "job.apt"
    job.write_text("FINI\n")
    assert find_part_beside(job) is None
    (tmp_path / "job.stl").write_text("solid\nendsolid\n")
    (tmp_path / "job.igs").write_text("")
    assert find_part_beside(job) == tmp_path / "job.igs"
    (tmp_path / "job.step").write_text("")
    assert find_part_beside(job) == tmp_path / "job.step"


@pytest.mark.parametrize(
    ("name", "content", "expect"),
    [
        ("bad.json", "{not json", "not valid geomdl exchange data"),
        ("shape.json", '{"shape": {"type": "curve", "data": []}}', "expected shape type 'surface'"),
        ("nodata.json", '{"foo": 1}', "expected a geomdl exchange document"),
        ("part.dxf", "0\nSECTION\n", "unsupported part file type '.dxf'"),
        ("bad.step", "ISO-10303-21;\nnonsense\n", "not a readable STEP file"),
        ("bad.stl", "solid x\nfacet normal 0 0 0\nouter loop\nvertex 1 2\n", "STL"),
    ],
)
def test_bad_part_files_name_the_file(tmp_path, name, content, expect):
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(PathcheckError) as err:
        load_part(path)
    assert err.value.code == "part" and expect in str(err.value) and name in str(err.value)


def test_geomdl_wrong_pole_count_is_reported(container, tmp_path):
    path, _ = container
    data = json.loads(path.read_text())
    data["shape"]["data"][1]["size_v"] = 8
    bad = tmp_path / "bad_count.json"
    bad.write_text(json.dumps(data))
    with pytest.raises(
        PathcheckError, match=r"surface 1: 35 control points with 3 coordinates, expected 5x8 = 40"
    ):
        load_part(bad)


def test_missing_file_is_a_part_error(tmp_path):
    with pytest.raises(PathcheckError, match="cannot read part file") as err:
        load_part(tmp_path / "nowhere.step")
    assert err.value.code == "part"


def test_describe_geomdl_part(container):
    from checker.geometry.part_info import describe_part, format_part_info

    path, surfs = container
    d = describe_part(path)
    assert [(s["degree_u"], s["poles_u"], s["poles_v"], s["rational"]) for s in d["surfaces"]] == [
        (5, 6, 6, True), (2, 5, 7, False),
    ]  # fmt: skip
    # the bbox is that of the evaluated surfaces: inside the control-point hull, touching corners
    pts = np.concatenate(
        [np.array(g.evaluate_list([[0, 0], [1, 1], [0, 1], [1, 0]])) for g in surfs]
    )
    hull = np.concatenate([np.array(g.ctrlpts) for g in surfs])
    lo, hi = np.array(d["bbox"]["min"]), np.array(d["bbox"]["max"])
    assert np.all(lo <= pts.min(axis=0) + 1e-9) and np.all(hi >= pts.max(axis=0) - 1e-9)
    assert np.all(lo >= hull.min(axis=0) - 1e-9) and np.all(hi <= hull.max(axis=0) + 1e-9)
    text = format_part_info(d)
    assert "2 surfaces (1 rational, 0 trimmed)" in text and "5x5" in text
