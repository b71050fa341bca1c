"""Machine definitions (TOML, pydantic) and the part <-> machine kinematics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from checker.errors import PathcheckError
from checker.postproc.kinematics import Chain, axis_from_rotation, rotation_from_axis
from checker.postproc.machine import available_machines, load_machine


def test_shipped_machines_load():
    names = available_machines()
    assert {"fanuc-hmc", "linuxcnc-hmc"} <= set(names)
    fanuc = load_machine()
    assert fanuc.name == "fanuc-hmc" and fanuc.dialect == "fanuc"
    linux = load_machine("linuxcnc-hmc")
    assert linux.dialect == "linuxcnc" and linux.feeds.rotary_mode == "g93"


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ('[rotary]\nwrap = "spiral"\n', "rotary_axes.0.wrap"),
        ("[rotary]\nb_min = 10.0\nb_max = -10.0\n", "rotary_axes.0.limits"),
        ("[travel]\nx = [5.0, -5.0]\n", "travel.x"),
        ('[[rotary_axes]]\nname = "D"\ndirection = [0, 1, 0]\n', "rotary_axes.0.name"),
        ('[[rotary_axes]]\nname = "A"\ndirection = [0, 0, 0]\n', "rotary_axes.0.direction"),
        ('[[rotary_axes]]\nname = "A"\non = "spindle"\ndirection = [1, 0, 0]\n',
         "rotary_axes.0.on"),
        ("[setup]\nrotation = [[1, 0, 0], [0, 1, 0], [0, 0, -1]]\n", "setup.rotation"),
        ("[format]\nlinear_increment = 0.005\n", "format.linear_increment': expected a power "
         "of ten from 1 to 0.000001"),
        ("[format]\nlinear_decimals = 12\n", "format': linear_decimals must be an integer 0..6"),
        ("[format]\nblock_max = 5\n", "format': block_max (5) must be at least block_start"),
        ("[feeds]\nmax_linear = -1\n", "feeds.max_linear"),
        ("colour = 'red'\n", "colour"),
        ('[program]\nheader = ["G17 \u00e9"]\n', "program.header"),
    ],
)
def test_invalid_machine_file_names_the_field(tmp_path, body, field):
    path = tmp_path / "bad.toml"
    path.write_text(f'name = "bad"\n{body}')
    with pytest.raises(PathcheckError) as err:
        load_machine(path)
    assert f"machine field '{field}" in str(err.value)
    assert str(path) in str(err.value)


def test_machine_file_errors(tmp_path):
    with pytest.raises(PathcheckError, match="unknown machine 'nope'.*fanuc-hmc"):
        load_machine("nope")
    broken = tmp_path / "broken.toml"
    broken.write_text("name = \n")
    with pytest.raises(PathcheckError, match="not valid TOML"):
        load_machine(broken)
    unsafe = tmp_path / "unsafe.toml"
    unsafe.write_text("[program]\nsafe_z = 900.0\n")
    with pytest.raises(PathcheckError, match="safe_z"):
        load_machine(unsafe)
    legacy = tmp_path / "legacy.toml"
    legacy.write_text("[kinematics]\nb_direction = 2\n")
    with pytest.raises(PathcheckError) as err:  # an error of the whole file: no field named
        load_machine(legacy)
    assert str(err.value) == f"{legacy}: machine: kinematics.b_direction must be 1 or -1, found 2"
    with pytest.raises(PathcheckError, match="machine file not found"):
        load_machine(tmp_path / "none.toml")


def _machine(center=(0.0, 0.0, 0.0), direction=1):
    return load_machine().with_options(
        rotary_axes=[{"point": center, "direction": (0.0, float(direction), 0.0)}]
    )


@pytest.mark.parametrize("direction", [1, -1])
def test_part_to_machine_matches_rotation_about_y(direction):
    rng = np.random.default_rng(3)
    center = np.array([12.0, -4.0, 30.0])
    machine = _machine(tuple(center), direction)
    p = rng.uniform(-100, 100, (50, 3))
    words = rng.uniform(-400, 400, 50)
    # docs/MATH.md §1: a part point p sits at Ry(b) (p - c) + c, b = b_direction * word
    expected = (
        Rotation.from_euler("y", direction * words[:, None], degrees=True).apply(p - center)
        + center
    )
    chain = Chain(machine)
    m = chain.inverse_position(p, words[:, None])
    assert np.allclose(m, expected, atol=1e-12)
    assert machine.kinematics.b_direction == direction
    assert np.allclose(machine.kinematics.table_center, center)
    tip, axis = chain.forward(m, words[:, None])
    assert np.allclose(tip, p, atol=1e-12)
    # the spindle (machine +Z) seen in the part frame
    spindle = (
        Rotation.from_euler("y", direction * words[:, None], degrees=True).inv().apply([0, 0, 1])
    )
    assert np.allclose(axis, spindle, atol=1e-12)


def test_axis_convention():
    b = np.array([0.0, 30.0, -90.0, 180.0])
    axis = axis_from_rotation(np.radians(b))
    assert np.allclose(axis[1], [-0.5, 0.0, np.sqrt(3) / 2])
    assert np.allclose(rotation_from_axis(axis), [0.0, 30.0, -90.0, 180.0])
    with pytest.raises(PathcheckError, match="not a 4-axis path about Y.*j = 0.1"):
        rotation_from_axis(np.array([[0.0, 0.1, 0.995]]), lines=np.array([7]))


def test_tip_path_length_pure_rotation_is_an_arc():
    machine = _machine()
    xyz = np.array([[50.0, 0.0, 0.0]])
    # the table turns 90 deg with the tool fixed at radius 50: the tip sweeps a quarter circle
    chain = Chain(machine)
    length = chain.tip_path_length(xyz, xyz, np.array([[0.0]]), np.array([[90.0]]))
    assert length[0] == pytest.approx(50 * np.pi / 2, rel=2e-3)
    straight = chain.tip_path_length(
        xyz, xyz + [3.0, 4.0, 0.0], np.array([[10.0]]), np.array([[10.0]])
    )
    assert straight[0] == pytest.approx(5.0, abs=1e-12)


def test_older_four_axis_form_reads_as_the_same_b_table(tmp_path):
    """A machine file in the older form ([kinematics] + one [rotary]) is the B table it
    describes: same chain, same program as the shipped file in the chain form."""
    from checker.postproc.post import PostMoves, post_program

    old = tmp_path / "old-hmc.toml"
    old.write_text(
        'name = "fanuc-hmc"\ndialect = "fanuc"\n'
        "[kinematics]\ntable_center = [10.0, 0.0, -5.0]\nb_direction = -1\n"
        '[rotary]\nwrap = "limited"\nb_min = -200.0\nb_max = 200.0\nmax_feed = 5400.0\n'
        "[travel]\nx = [-400.0, 400.0]\ny = [-350.0, 350.0]\nz = [-300.0, 450.0]\n"
        '[program]\nsafe_z = 250.0\nheader = ["G17 G40 G49 G80 G90", "G54"]\n'
        'footer = ["M05", "M09", "G91 G28 Z0.0", "G90", "M30"]\n'
        'tool_change = ["G91 G28 Z0.0", "G90", "T{tool:02d} M06"]\n'
    )
    legacy = load_machine(old)
    assert legacy.kind == "table B" and legacy.rotary.wrap == "limited"
    assert legacy.rotary.b_min == -200.0 and legacy.kinematics.b_direction == -1
    assert legacy.kinematics.table_center == (10.0, 0.0, -5.0)
    chain_form = load_machine("fanuc-hmc").with_options(rotary_axes=[{
        "direction": (0.0, -1.0, 0.0), "point": (10.0, 0.0, -5.0), "wrap": "limited",
        "limits": (-200.0, 200.0)}])
    b = np.linspace(-30, 150, 40)
    tip = np.c_[50 * np.sin(np.radians(b)), np.zeros(40), 50 * np.cos(np.radians(b))]
    moves = PostMoves.build(tip, b, feed=500.0, tool=1)
    assert post_program(moves, legacy) == post_program(moves, chain_form)


def test_older_decimals_are_read_as_increments(tmp_path):
    path = tmp_path / "old.toml"
    path.write_text('name = "old"\n[format]\nlinear_decimals = 4\nrotary_decimals = 5\n')
    fmt = load_machine(path).format
    assert (fmt.linear_increment, fmt.inch_increment, fmt.rotary_increment) == (1e-4, 1e-4, 1e-5)
    assert (fmt.linear_decimals("mm"), fmt.linear_decimals("inch"), fmt.rotary_decimals) == (
        4, 4, 5)
