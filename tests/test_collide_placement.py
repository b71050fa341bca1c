"""The placements of the machine check (`checker.collide.placement`) against the chain's own
forward kinematics (`postproc.kinematics.Chain.forward`): the tool's tip and axis carried by the
head's links meet the part-frame tip and axis carried by the table's links, on every shipped
machine, with and without tool-centre-point control; and the speed bound holds between poses."""

from __future__ import annotations

import numpy as np
import pytest

from checker.collide.placement import Links
from checker.postproc.kinematics import Chain
from checker.postproc.machine import available_machines, load_machine


@pytest.mark.parametrize("name", available_machines())
@pytest.mark.parametrize("tcp", [False, True])
def test_tool_side_meets_work_side(name, tcp):
    chain = Chain(load_machine(name))
    rng = np.random.default_rng(4)
    n = 50
    xyz = rng.uniform(-200, 200, (n, 3))
    joints = rng.uniform(-120, 120, (n, chain.k))
    tip, axis = chain.forward(xyz, joints, tcp)  # part frame
    links = Links(chain)
    X = links.machine_x(xyz, joints, tcp)
    table, head = links.place(X, joints)
    n_setup = links.setup
    work_tip = tip @ n_setup.R[0].T + n_setup.t[0]
    on_table = table[-1].apply(work_tip)
    on_head = head[-1].apply(np.zeros(3))
    assert np.allclose(on_table, on_head, atol=1e-9)
    ax_table = np.einsum("nij,nj->ni", table[-1].R, axis @ n_setup.R[0].T)
    ax_head = head[-1].R[:, :, 2]
    assert np.allclose(ax_table, ax_head, atol=1e-12)


@pytest.mark.parametrize("name", ["fanuc-trunnion-ac", "linuxcnc-head-head-ac",
                                  "dmu70evo-840d", "linuxcnc-xyzab-tdr"])
@pytest.mark.parametrize("tcp", [False, True])
def test_speed_bound_holds(name, tcp):
    """A point 300 mm from the last pivot of each side: its travel between 200 sub-steps of a
    move never exceeds the bound (per unit t) times the step."""
    chain = Chain(load_machine(name))
    links = Links(chain)
    rng = np.random.default_rng(7)
    xyz = rng.uniform(-100, 100, (2, 3))
    joints = rng.uniform(-60, 60, (2, chain.k))
    t = np.linspace(0.0, 1.0, 201)
    xs = xyz[0] + t[:, None] * (xyz[1] - xyz[0])
    js = joints[0] + t[:, None] * (joints[1] - joints[0])
    X = links.machine_x(xs, js, tcp)
    table, head = links.place(X, js)
    turn = np.radians(np.abs(joints[1] - joints[0]))
    vx = links.x_speed(xyz, joints, np.array([0]), np.array([1]), tcp)[0]
    p = np.array([170.0, -150.0, 190.0])  # |p| ~ 300
    for side, placed in (("table", table), ("head", head)):
        for j in range(1, len(placed)):
            c = links.pivot(side, j)
            arm = np.linalg.norm(p - c)
            arms = links.table_arms(j, arm) if side == "table" else links.head_arms(j, arm)
            bound = turn @ arms + (vx if side == "head" else 0.0)
            path = placed[j].apply(p)
            step = np.linalg.norm(np.diff(path, axis=0), axis=1).max() / (t[1] - t[0])
            assert step <= bound * (1 + 1e-6) + 1e-9, (side, j, step, bound)
