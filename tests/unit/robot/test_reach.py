"""The reach model: the working branch's annulus, as the arm's own IK finds it."""

from __future__ import annotations

import math

import numpy as np

from msgs_py.cell import ACTION_HEIGHTS, TRAVEL_HEIGHT
from nodes.common.transforms import tool_down_matrix
from nodes.robot.kinematics import solve_tcp_ik
from nodes.robot.reach import (
    on_working_branch,
    ur10e_reach,
    working_branch_reaches,
    working_reference,
)


def test_the_reach_annulus_agrees_with_the_arms_ik_at_every_action_height():
    reach = ur10e_reach()
    rng = np.random.default_rng(4)
    for _ in range(150):
        r = rng.uniform(0.0, 1.6)
        a, yaw = rng.uniform(-math.pi, math.pi, 2)
        x, y = r * math.cos(a), r * math.sin(a)
        inside = bool(reach.contains((x, y)))
        by_ik = all(working_branch_reaches(x, y, z, yaw) for z in ACTION_HEIGHTS)
        margin = min(abs(r - reach.r_min), abs(r - reach.r_max))
        if margin > 0.011:  # the annulus is the IK's, shrunk by a 1 cm safety margin
            assert inside == by_ik, (x, y, yaw)
        elif inside:
            assert by_ik


def test_past_the_working_branchs_reach_only_the_other_wrist_branch_is_left():
    """Why the reach is the working branch's: just past it the IK still solves, on the wrist
    branch a stream of setpoints could only reach by a wrist flip."""
    reach = ur10e_reach()
    azimuth = -0.3
    for r, on_branch in ((reach.r_max - 0.02, True), (reach.r_max + 0.04, False)):
        t = np.eye(4)
        t[:3, :3] = tool_down_matrix(0.0)
        t[:3, 3] = (r * math.cos(azimuth), r * math.sin(azimuth), TRAVEL_HEIGHT)
        ik = solve_tcp_ik(t, working_reference(azimuth))
        assert ik.ok
        assert on_working_branch(ik.q, azimuth) is on_branch
        assert bool(ik.q[4] > 0) is on_branch  # wrist 2 turned from +90 to -90 deg


def test_a_straight_carry_past_the_base_is_out_of_reach():
    reach = ur10e_reach()
    assert reach.segment((0.8, 0.4), (0.8, -0.4))
    assert not reach.segment((0.6, 0.05), (-0.6, -0.05))  # through the column of the base
