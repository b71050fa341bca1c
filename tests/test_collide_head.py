"""The machine check on a head-head machine: the head tilting until its spindle nose meets a box
fixture of known height, found at the angle of the closed form; a pose short of it is clear."""

from __future__ import annotations

import math

from collide_machines import check, machine_file
from requires import require_extra

require_extra("coal", "machine")

PIVOT = 150.0  # the A axis above the spindle nose (linuxcnc-head-head-ac: point z 150)
R_NOSE = 60.0
CLEARANCE = 0.5
TOP = 91.15  # the fixture's top, machine Z (the tip at Z 0 at every word 0)
NOSE = f"""
[[components]]
name = "nose"
link = "spindle"
cylinder = {{ radius = {R_NOSE}, start = [0.0, 0.0, 0.0], end = [0.0, 0.0, 40.0] }}

[[components]]
name = "block"
link = "bed"
box = {{ min = [-200.0, -400.0, -500.0], max = [200.0, -20.0, {TOP}] }}
"""


def contact_angle() -> float:
    """The A (degrees) at which the nose comes within the clearance of the block.

    The tool length is 100 mm, so at X = Y = Z = 0 the nose is at Z 100 and the A pivot at
    Z 250 = 100 + PIVOT. Turning by A about +X, the nose's face centre is at (0, PIVOT sin A,
    250 - PIVOT cos A) and its rim's lowest point R_NOSE further along -(0, cos A, sin A): at
    Z = 250 - (PIVOT cos A + R_NOSE sin A) = 250 - R cos(A - phi), R = hypot(PIVOT, R_NOSE),
    phi = atan2(R_NOSE, PIVOT), at Y = PIVOT sin A - R_NOSE cos A (over the block, whose edge is
    Y -20, while A < 14 deg). It is CLEARANCE above the block's top when R cos(A - phi) = 250 -
    TOP - CLEARANCE: A* = phi - acos((250 - TOP - CLEARANCE) / R) = 10.37 deg. The tool (6 mm,
    24 long) swings to +Y, away from the block."""
    R = math.hypot(PIVOT, R_NOSE)
    phi = math.atan2(R_NOSE, PIVOT)
    return math.degrees(phi - math.acos((250.0 - TOP - CLEARANCE) / R))


def test_head_tilt_meets_the_block_at_the_closed_form_angle(tmp_path):
    a_star = contact_angle()
    assert abs(a_star - 10.37) < 0.01  # between the 1 deg poses the program is read in
    machine = machine_file(tmp_path, "linuxcnc-head-head-ac", NOSE)
    doc = check(tmp_path, machine, "G21 G90 G94\nG0 X0 Y0 Z0 A0 C0\nG1 X1 F1000\n"
                                   "G1 A20 F1000\nM30\n", "--machine-clearance", "0.5")
    m = doc["machine"]
    assert doc["summary"]["status"] == "findings"
    first = m["findings"][0]
    assert (first["a"], first["b"]) == ("block", "nose")
    assert first["line"] == 4
    assert abs(first["axes"]["A"] - a_star) < 0.05, (first["axes"], a_star)
    assert first["distance"] < CLEARANCE


def test_head_tilt_short_of_the_angle_is_clear(tmp_path):
    """Stopping 0.1 deg short of A*: no finding, and the least clearance is the nose's height
    over the block there, 250 - R cos(A - phi) - TOP (the near-miss listing)."""
    a = contact_angle() - 0.1
    machine = machine_file(tmp_path, "linuxcnc-head-head-ac", NOSE)
    doc = check(tmp_path, machine, f"G21 G90 G94\nG0 X0 Y0 Z0 A0 C0\nG1 X1 F1000\n"
                                   f"G1 A{a:.4f} F1000\nM30\n", "--machine-clearance", "0.5")
    m = doc["machine"]
    assert m["findings"] == [] and doc["summary"]["status"] == "ok"
    R, phi = math.hypot(PIVOT, R_NOSE), math.atan2(R_NOSE, PIVOT)
    gap = 250.0 - R * math.cos(math.radians(a) - phi) - TOP
    near = {(p["a"], p["b"]): p["least"] for p in m["near_misses"]}
    assert abs(near[("block", "nose")] - gap) < 0.01, (near, gap)
