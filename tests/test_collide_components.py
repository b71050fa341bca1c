"""Machine components in the machine file: a wrong link, two shapes or a missing mesh is one
clear error naming the file; an STL component beside the machine file is measured like the box
it is (the same distance as the primitive box to a cylinder, against the closed form)."""

from __future__ import annotations

import numpy as np
import pytest
from collide_machines import machine_file
from requires import require_extra
from stl import mesh as stl_mesh

from checker.collide.solids import component_shape
from checker.config import Config
from checker.errors import PathcheckError
from checker.postproc.machine import load_machine_file

coal = require_extra("coal", "machine")


def _box_stl(path, lo, hi) -> None:
    """A closed box as 12 outward triangles."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[(hi if i else lo)[0], (hi if j else lo)[1], (hi if k else lo)[2]]
                  for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    faces = [(0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
             (2, 6, 7), (2, 7, 3), (0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5)]
    m = stl_mesh.Mesh(np.zeros(len(faces), dtype=stl_mesh.Mesh.dtype))
    for f, tri in enumerate(faces):
        m.vectors[f] = c[list(tri)]
    m.save(str(path))


@pytest.mark.parametrize(("text", "expected"), [
    ('[[components]]\nname = "x"\nlink = "D"\nbox = { min = [0, 0, 0], max = [1, 1, 1] }',
     "link 'D'"),
    ('[[components]]\nname = "x"\nlink = "bed"\nbox = { min = [0, 0, 0], max = [1, 1, 1] }\n'
     'cylinder = { radius = 1, start = [0, 0, 0], end = [0, 0, 1] }', "exactly one of"),
    ('[[components]]\nname = "x"\nlink = "bed"\nbox = { min = [0, 0, 0], max = [1, -1, 1] }',
     "above min"),
    ('[[components]]\nname = "x"\nlink = "A"\nmoves = "y"\n'
     'box = { min = [0, 0, 0], max = [1, 1, 1] }', "`moves` is for components of the bed"),
])
def test_bad_component_is_one_clear_error(tmp_path, text, expected):
    path = machine_file(tmp_path, "fanuc-trunnion-ac", text)
    with pytest.raises(PathcheckError) as err:
        load_machine_file(path)
    assert expected in err.value.message and path.name in str(err.value)


def test_missing_mesh_names_the_file(tmp_path):
    path = machine_file(tmp_path, "fanuc-trunnion-ac",
                        '[[components]]\nname = "vise"\nlink = "C"\nmesh = "vise.stl"')
    machine = load_machine_file(path)
    with pytest.raises(PathcheckError) as err:
        component_shape(machine.components[0], Config())
    assert "vise.stl" in str(err.value) and "mesh file not found" in err.value.message


def test_stl_component_measures_like_its_box(tmp_path):
    """A box [0, 100] x [0, 50] x [0, 20] and a cylinder of radius 5 along Z whose axis is at
    (130, 25) from z 0 to 40: 130 - 100 - 5 = 25 mm apart, whether the box is an STL or a
    primitive; moved to x = 102 the cylinder is 3 mm inside."""
    _box_stl(tmp_path / "block.stl", [0, 0, 0], [100, 50, 20])
    path = machine_file(tmp_path, "fanuc-trunnion-ac",
                        '[[components]]\nname = "block"\nlink = "C"\nmesh = "block.stl"\n\n'
                        '[[components]]\nname = "block2"\nlink = "C"\n'
                        'box = { min = [0, 0, 0], max = [100, 50, 20] }')
    machine = load_machine_file(path)
    cfg = Config()
    cyl = coal.Cylinder(5.0, 40.0)
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    for comp in machine.components:
        shape = component_shape(comp, cfg)
        at = coal.Transform3s(shape.R0, shape.t0)
        for x, want in ((130.0, 25.0), (102.0, -3.0)):
            res.clear()
            d = coal.distance(shape.geom, at, cyl,
                              coal.Transform3s(np.eye(3), np.array([x, 25.0, 20.0])), req, res)
            if want > 0 or comp.mesh is None:  # a mesh is its surface: no depth inside
                assert abs(d - want) < 1e-6, (comp.name, x, d)


@pytest.mark.parametrize(("args", "expected"), [
    (["--machine", "linuxcnc-hmc", "--machine-check"], "has no components"),
    (["--machine", "fanuc-trunnion-ac", "--machine-clearance", "-1"], "expected a distance"),
])
def test_machine_check_usage_errors(tmp_path, capsys, args, expected):
    """A machine without solids, a negative clearance: one line, exit 2, before any work."""
    from checker.cli import main

    prog = tmp_path / "p.nc"
    prog.write_text("G21 G90\nG0 X0 Y0 Z50\nG1 X10 F100\nM30\n")
    with pytest.raises(SystemExit) as ex:
        main(["check-gcode", str(prog), "--cutter", "CUTTER/6", "--no-store", *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert ex.value.code == 2 and len(err) == 1 and expected in err[0], err
