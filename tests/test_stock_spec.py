"""The `--stock` text (`checker.stock.spec`) and the stock a CL file states
(`checker.stock.stated`), the latter measured on the amorim SolidWorks CAM jobs of realdata."""

from __future__ import annotations

import numpy as np
import pytest

from checker.apt import read_cl
from checker.apt.read import read_cl_text
from checker.errors import PathcheckError
from checker.stock.spec import (
    Box,
    BoxCorners,
    BoxMargins,
    Cylinder,
    CylinderGiven,
    CylinderMargin,
    FromCL,
    SolidFile,
    SolidPath,
    parse_stock,
    resolve,
)
from checker.stock.stated import StatedStock, place, stated_stock

PART = np.array([[10.0, 20.0, -30.0], [60.0, 50.0, -5.0]])


def test_box_margin_forms_around_the_part():
    one = resolve(parse_stock("box:+3"), PART, None)
    assert isinstance(one, Box)
    np.testing.assert_allclose(one.lo, PART[0] - 3)
    np.testing.assert_allclose(one.hi, PART[1] + 3)
    axes = resolve(parse_stock("box:+1,+2,+0.5"), PART, None)
    np.testing.assert_allclose(axes.lo, PART[0] - [1, 2, 0.5])
    np.testing.assert_allclose(axes.hi, PART[1] + [1, 2, 0.5])
    sides = resolve(parse_stock(" BOX: +1, +2, +3, +4, +5, +6 "), PART, None)
    np.testing.assert_allclose(sides.lo, PART[0] - [1, 3, 5])
    np.testing.assert_allclose(sides.hi, PART[1] + [2, 4, 6])
    assert parse_stock("box:+2") == BoxMargins((2.0,) * 3, (2.0,) * 3)


def test_box_corners_need_no_part():
    spec = parse_stock("box:0,0,-30,135,135.5,0")
    assert spec == BoxCorners((0.0, 0.0, -30.0), (135.0, 135.5, 0.0))
    box = resolve(spec, None, None)
    np.testing.assert_allclose(box.hi - box.lo, [135, 135.5, 30])


def test_cylinder_margin_radius_is_the_farthest_point_plus_the_margin():
    spec = parse_stock("cylinder:x:+2")
    assert spec == CylinderMargin("x", (0.0, 0.0), 2.0)
    # a bar part of radius 10 about X, from x = 0 to 100: points on its circle
    t = np.linspace(0, 2 * np.pi, 73)
    pts = np.column_stack([np.repeat([0.0, 100.0], 73), np.tile(10 * np.cos(t), 2),
                           np.tile(10 * np.sin(t), 2)])
    box = np.array([pts.min(0), pts.max(0)])
    cyl = resolve(spec, box, None, part_points=pts)
    assert isinstance(cyl, Cylinder)
    assert cyl.radius == pytest.approx(12.0)
    assert (cyl.start, cyl.end) == pytest.approx((-2.0, 102.0))
    # without the points the box's corners bound it: 10 sqrt(2) + 2
    assert resolve(spec, box, None).radius == pytest.approx(10 * np.sqrt(2) + 2)


def test_cylinder_off_the_origin_and_explicit():
    spec = parse_stock("cylinder:x@0,10:40,-5,105")
    assert spec == CylinderGiven("x", (0.0, 10.0), 40.0, -5.0, 105.0)
    cyl = resolve(spec, None, None)
    assert (cyl.radius, cyl.start, cyl.end) == (20.0, -5.0, 105.0)
    np.testing.assert_allclose(cyl.centre, [0.0, 10.0])
    assert cyl.others == (1, 2)
    # the axis Z through (x, y) = (35, 35): the part's box corners are 25 and 15 away
    cz = resolve(parse_stock("cylinder:Z@35,35:+1"), PART, None)
    assert cz.radius == pytest.approx(np.hypot(25, 15) + 1)
    assert (cz.start, cz.end) == pytest.approx((-31.0, -4.0))


def test_solid_file_and_cl(tmp_path):
    f = tmp_path / "bar.STL"
    f.write_bytes(b"solid x\nendsolid x\n")
    assert parse_stock(str(f)) == SolidPath(f)
    assert isinstance(resolve(parse_stock(str(f)), None, None), SolidFile)
    assert parse_stock(" CL ") == FromCL()
    stated = StatedStock(np.array([135.0, 135.0, 30.0]), 11)
    box = resolve(FromCL(), None, stated)
    np.testing.assert_allclose(box.lo, [0, 0, -30])
    assert "line 11" in box.how


@pytest.mark.parametrize("text, expected", [
    ("box:+3,+4", "found 2 number"),
    ("box:+1,2,+3", "cannot be mixed"),
    ("box:+-1", "margin is >= 0"),
    ("box:0,0,0,1,1,0", "Z1 must be greater than Z0"),
    ("box:1,2,3,4,5,nan", "not a finite number"),
    ("box:+a", "'+a' is not a number"),
    ("cylinder:w:+2", "AXIS x, y or z"),
    ("cylinder:x@1:+2", "@C1,C2 is two numbers"),
    ("cylinder:x:0,0,10", "diameter D must be > 0"),
    ("cylinder:x:10,5,5", "END must be greater than START"),
    ("cylinder:x:+1,+2", "cylinder:AXIS"),
    ("sphere:3", "box:+M"),
    ("/no/such/stock.step", "does not exist"),
])
def test_bad_text_is_one_usage_line(text, expected):
    with pytest.raises(PathcheckError) as err:
        parse_stock(text)
    assert err.value.code == "usage"
    assert expected in str(err.value) and "\n" not in str(err.value)
    assert "--stock" in str(err.value)


def test_what_is_missing_is_said():
    with pytest.raises(PathcheckError, match="needs the part"):
        resolve(parse_stock("box:+3"), None, None)
    with pytest.raises(PathcheckError, match="needs the part"):
        resolve(parse_stock("cylinder:z:+3"), None, None)
    with pytest.raises(PathcheckError, match="states no stock"):
        resolve(parse_stock("cl"), PART, None)
    flat = np.array([[0.0, 0.0, 0.0], [10.0, 10.0, 0.0]])
    with pytest.raises(PathcheckError, match="flat"):
        resolve(parse_stock("box:+1,+1,+0"), flat, None)


_PROGRAM = "FEDRAT/100\nCUTTER/6,0\nGOTO/0,0,0\nGOTO/10,0,0\n"


def test_stated_stock_read_and_converted_from_inches():
    tp = read_cl_text(f"UNIT/INCH\nINSERT/Stock Size X1. Y2.5 Z.5\n{_PROGRAM}")
    s = stated_stock(tp)
    np.testing.assert_allclose(s.size, [25.4, 63.5, 12.7])
    assert s.line == 2
    assert stated_stock(read_cl_text(f"INSERT/Stock Size X1 Y2\n{_PROGRAM}")) is None
    assert stated_stock(read_cl_text(f"INSERT/Stock Size X1 Y0 Z3\n{_PROGRAM}")) is None
    assert stated_stock(read_cl_text(_PROGRAM)) is None


def test_place_a_stated_stock_that_fits_and_one_that_does_not():
    s = StatedStock(np.array([70.0, 40.0, 30.0]), 7)
    box, how = place(s, PART)  # part 50 x 30 x 25 below Z 0: centred in X, Y, top at 0
    np.testing.assert_allclose(box, [[0, 15, -30], [70, 55, 0]])
    assert "centred on the part in X and Y, top at Z 0" in how and "does not fit" not in how
    high = PART + [0, 0, 20]  # the part stands above Z 0: top at the part's top
    box, how = place(s, high)
    np.testing.assert_allclose(box[:, 2], [-15, 15])
    assert "the part's top Z 15" in how
    small = StatedStock(np.array([40.0, 40.0, 30.0]), 7)
    assert "stands 5 mm out along X" in place(small, PART)[1]


# the amorim SolidWorks CAM jobs with their part's STL
AMORIM = ("Interface-glue.STL", "RotateThin.STL", "Sacrifice-Board.STL",
          "Teste-Metrologia.STL", "Telemecanique-Tilt-Support1.stl")


def _job(realdata, name):
    from stl import mesh

    folder = realdata / "amorim-solidworkscam-apt"
    tp = read_cl(folder / (name.rsplit(".", 1)[0] + ".apt"))
    v = mesh.Mesh.from_file(str(folder / name)).vectors.reshape(-1, 3).astype(float)
    return tp, np.array([v.min(0), v.max(0)])


def test_every_amorim_job_states_its_stock(realdata):
    sizes = {name: stated_stock(_job(realdata, name)[0]) for name in AMORIM}
    assert {n: (s.size.tolist(), s.line) for n, s in sizes.items()} == {
        "Interface-glue.STL": ([135, 135, 30], 11), "RotateThin.STL": ([293.7, 100, 9], 11),
        "Sacrifice-Board.STL": ([440, 170, 30], 11), "Teste-Metrologia.STL": ([85, 38, 48], 9),
        "Telemecanique-Tilt-Support1.stl": ([45, 30, 37.75], 11)}


@pytest.mark.parametrize("name, corners", [
    ("Interface-glue.STL", [[0, 0, -30], [135, 135, 0]]),
    ("Sacrifice-Board.STL", [[0, 0, -30], [440, 170, 0]]),
    ("Teste-Metrologia.STL", [[0, 0, -48], [85, 38, 0]]),
])
def test_stated_stock_placed_against_the_part(realdata, name, corners):
    """Where the STL is the part alone, centred on it in X and Y with the top at Z 0 is the box
    with its top's low corner at the CL origin, and the part lies inside it."""
    tp, part = _job(realdata, name)
    box, how = place(stated_stock(tp), part)
    np.testing.assert_allclose(box, corners, atol=1e-3)
    np.testing.assert_allclose(place(stated_stock(tp), None)[0], corners, atol=1e-9)
    assert (part[0] >= box[0] - 1e-3).all() and (part[1] <= box[1] + 1e-3).all()
    assert "does not fit" not in how


def test_sacrifice_board_faces_one_mm_into_both_faces(realdata):
    """Sacrifice-Board's face mill (D50) takes its first pass 1 mm below the placed stock's top
    (the first setup) and 1 mm above its bottom (the flipped setup): the stock is Z -30..0, not
    bottom at the part's bottom (-27.5..2.5)."""
    tp, part = _job(realdata, "Sacrifice-Board.STL")
    box, _ = place(stated_stock(tp), part)
    m = tp.motions
    d50 = [k for k, op in enumerate(tp.operations) if op.cutter and op.cutter.d == 50.0]
    face = np.isin(m.op, d50)
    z = m.tip[face & ~np.asarray(m.rapid, bool), 2]
    top, bottom = z[z > -15], z[z < -15]
    assert top.max() == pytest.approx(box[1, 2] - 1.0)
    assert bottom.min() == pytest.approx(box[0, 2] + 1.0)


def test_rotatethin_cuts_are_centred_on_the_stated_stock(realdata):
    """RotateThin's STL holds more than the part (700 x 500 x 229 mm): placed against it the
    stock is said not to fit; without it the stock is [0, X] x [0, Y] x [-Z, 0], on whose centre
    the cutting moves (a contour around it) are centred and whose bottom they reach."""
    tp, part = _job(realdata, "RotateThin.STL")
    s = stated_stock(tp)
    assert "does not fit" in place(s, part)[1]
    box, how = place(s, None)
    cut = tp.motions.tip[~np.asarray(tp.motions.rapid, bool)]
    mid = (cut.min(0) + cut.max(0)) / 2
    np.testing.assert_allclose(mid[:2], (box[0, :2] + box[1, :2]) / 2, atol=1e-3)
    assert cut[:, 2].min() == pytest.approx(box[0, 2]) and cut[:, 2].max() <= box[1, 2]
    assert "top's low corner at the origin" in how


def test_telemecanique_stated_stock_is_smaller_than_its_part(realdata):
    """The tilted-setup job states 45 x 30 x 37.75 mm for a part 38.8 x 45 x 40 mm in the part
    frame: no placement fits; it is said."""
    tp, part = _job(realdata, "Telemecanique-Tilt-Support1.stl")
    _, how = place(stated_stock(tp), part)
    assert "does not fit" in how and "along Y" in how
