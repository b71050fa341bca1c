"""The machine check on a trunnion A/C (fanuc-trunnion-ac's chain): the tilted table meeting the
column at the Y of the closed form, on the right line; the least clearance of a program that
stops short of it (the near-miss listing); a C swing whose two ends are clear but whose middle
passes through the column (found along the move, between the checked poses)."""

from __future__ import annotations

from collide_machines import check, machine_file
from requires import require_extra

require_extra("coal", "machine")

PLATTER = """
[[components]]
name = "platter"
link = "C"
cylinder = { radius = 150.0, start = [0.0, 0.0, -40.0], end = [0.0, 0.0, 0.0] }
"""
COLUMN = """
[[components]]
name = "column"
link = "bed"
moves = "y"
box = { min = [-500.0, -1000.0, -600.0], max = [500.0, -300.0, 1000.0] }
"""
# at A = 90 the platter's top face (80 mm above the A axis at Z -80) faces -Y: Y -80; the
# column's front is at machine Y - 300; the gap is 220 - Y
PROGRAM = ("G21 G90 G94\nG0 X0 Y0 Z200 A90 C0\nG1 Y100 F1000\nG1 Y200\nG1 Y250\nG1 Y0\nM30\n")


def test_tilted_table_meets_the_column_on_the_right_line(tmp_path):
    """Clearance 1 mm: the gap 220 - Y falls below it past Y = 219, on line 5 (Y 200 -> 250)."""
    machine = machine_file(tmp_path, "fanuc-trunnion-ac", PLATTER + COLUMN)
    doc = check(tmp_path, machine, PROGRAM)
    m = doc["machine"]
    assert len(m["findings"]) == 1, m["findings"]
    f = m["findings"][0]
    assert (f["a"], f["b"], f["line"]) == ("platter", "column", 5)
    assert abs(f["axes"]["Y"] - 219.0) < 0.01 and abs(f["axes"]["A"] - 90.0) < 1e-6
    assert abs(f["distance"] - (220.0 - 250.0)) < 1e-3  # the deepest: at Y 250, 30 mm in
    assert doc["summary"]["status"] == "findings" and doc["summary"]["counts"]["machine"] == 1


def test_least_clearance_is_reported(tmp_path):
    """Stopping at Y 219.5 with a clearance of 0.25 mm: no finding; the near-miss listing gives
    the platter and the column 220 - 219.5 = 0.5 mm apart, at line 4."""
    machine = machine_file(tmp_path, "fanuc-trunnion-ac", PLATTER + COLUMN)
    doc = check(tmp_path, machine, "G21 G90 G94\nG0 X0 Y0 Z200 A90 C0\nG1 Y100 F1000\n"
                                   "G1 Y219.5\nG1 Y0\nM30\n", "--machine-clearance", "0.25")
    m = doc["machine"]
    assert m["findings"] == [] and m["clearance"] == 0.25
    near = m["near_misses"][0]
    assert (near["a"], near["b"], near["line"]) == ("platter", "column", 4)
    assert abs(near["least"] - 0.5) < 0.005
    assert abs(near["axes"]["Y"] - 219.5) < 0.01


CLAMP = """
[[components]]
name = "clamp"
link = "C"
box = { min = [130.0, -0.2, 0.0], max = [150.0, 0.2, 30.0] }

[[components]]
name = "post"
link = "bed"
moves = "y"
box = { min = [-0.5, -1000.0, -600.0], max = [0.5, -300.0, 1000.0] }
"""


def test_c_swing_through_the_post_between_poses(tmp_path):
    """A = 90, Y 200: the clamp (radially 130..150 mm from the C axis, 0.4 wide, 30 tall) reaches
    Y -110 (80 + 30 above the A axis), past the post's front at Y -100; the post is 1 mm wide
    about X 0. C turns 44.5 -> 135.5, read in 1 deg steps (poses at C = 89.5 and 90.5): there the
    clamp's X spans 130 cos(89.5) - 0.2 = 0.93 .. 1.51 mm, 0.43 mm from the post, clear of the
    0.1 mm clearance at every pose; at C = 90 it is inside. Found along the move, between them."""
    machine = machine_file(tmp_path, "fanuc-trunnion-ac", PLATTER + CLAMP)
    doc = check(tmp_path, machine, "G21 G90 G94\nG0 X0 Y200 Z200 A90 C44.5\n"
                                   "G1 C135.5 F1000\nM30\n", "--machine-clearance", "0.1")
    m = doc["machine"]
    hits = [f for f in m["findings"] if (f["a"], f["b"]) == ("clamp", "post")]
    assert len(hits) == 1, m["findings"]
    f = hits[0]
    assert f["line"] == 3 and 0.0 < f["t"] < 1.0
    assert 89.5 < f["axes"]["C"] < 90.5
    assert f["distance"] < 0.0


def test_least_clearance_of_a_far_pair_along_one_long_move(tmp_path):
    """The tool (tip at Z 200, A = C = 0) crosses the whole platter (top at Z 0) in one move
    from X -1000 to X 1000: the least clearance is 200 mm, over the platter, between the two
    poses (each 870 mm away); the spheres' gap there (68 mm, a lower bound) is not it. Found
    along the move to the listing's precision (1 % of the distance)."""
    machine = machine_file(tmp_path, "fanuc-trunnion-ac", PLATTER)
    doc = check(tmp_path, machine, "G21 G90 G94\nG0 X-1000 Y0 Z200 A0 C0\nG1 X1000 F5000\n"
                                   "M30\n")
    (near,) = doc["machine"]["near_misses"]
    assert (near["a"], near["b"], near["line"]) == ("platter", "tool body", 3)
    assert abs(near["least"] - 200.0) <= 2.0, near
    assert abs(near["axes"]["X"]) <= 150.0  # over the platter
