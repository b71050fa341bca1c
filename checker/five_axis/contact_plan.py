"""The contact-order planner of one multi-axis operation (`--reorient --strategy
contact-order`; docs/MATH.md §11.4, §13): flat-end and bull-nose finishing with the tool axis
of the highest-order contact (Liu et al. n.d.) at every contact row, smoothed by the MB-spline
fairing (Hwang et al. 2011).

The contact rows, their CC points, normals, feed directions, surfaces and (u, v), the judge
(the real tool with holder) and the machine's reach are those of the allowable planner
(`plan.operation_setting`). At each contact row `contact_order.contact_order_axes` derives the
pose and raises its lead until it is accepted, the acceptance being the judge's and the
machine's (`machine_reach`: within its rotary limits, outside its singular cone), up to
`five_axis.lead_limit_deg`. A row where no raise is accepted keeps the CAM's axis and is
flagged infeasible. Then the MB-spline fairing with the same oracle (`plan.finish_plan`): an
axis it moves stays accepted. Part frame, mm, rad."""

from __future__ import annotations

import math

import numpy as np

from checker.five_axis.contact_order import contact_order_axes
from checker.five_axis.posture import Posture
from checker.five_axis.reorient import FivePlan, finish_plan, operation_setting

METHOD = "contact order (Liu et al.)"


def plan_contact_order(job, rows: np.ndarray, op_rows: np.ndarray, cutter, tolerance: float,
                       chain, cfg) -> FivePlan | None:
    """The contact-order plan of one multi-axis operation (module docstring), arguments as
    `plan.plan_operation`; `cutter` flat-end or bull-nose (a ball family raises ValueError).
    None where no cutting row touches the part."""
    fa = cfg.five_axis
    st = operation_setting(job, rows, cutter, tolerance, chain, cfg)
    if st is None:
        return None
    con = st.contacts
    got = contact_order_axes(job.part, cutter, con.cc, con.normal, st.feeds, con.surface,
                             con.uv, judge=st.accepted, scallop=fa.scallop_height,
                             max_lead=math.radians(fa.lead_limit_deg))
    axis = np.where(got.found[:, None], got.axes, st.cam_axis)
    planned = Posture(axis, got.found, METHOD)
    return finish_plan(job, st, op_rows, cutter, planned, cfg, contact=got)
