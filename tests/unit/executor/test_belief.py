"""What the executor believes: the plan's current action, the camera check, the goal's yaw."""

from __future__ import annotations

import dataclasses
import math

from msgs_py.cell import table_margin_of
from nodes.executor.belief import Belief
from nodes.executor.camera_check import probe_actions
from nodes.executor.primitives import GRASP_SYMMETRY
from tests.unit.executor.world import START, WS, two_action_plan


def test_the_current_action_follows_the_index_and_ends_past_the_plan():
    belief = Belief()
    assert belief.current is None and belief.scene is None
    plan = two_action_plan()
    belief.adopt(plan)
    assert belief.current == plan.actions[0]
    belief.index = 3
    assert belief.current is None


def test_the_camera_checks_entries_are_counted_apart_from_the_plans():
    belief = Belief()
    plan = two_action_plan()
    belief.adopt(dataclasses.replace(plan, actions=probe_actions(2, START[1].pose)
                                     + plan.actions))
    belief.probes = 1
    assert belief.checking_camera
    belief.index = 1
    assert not belief.checking_camera and belief.current == plan.actions[0]
    belief.adopt(plan)  # a new plan starts without them
    assert (belief.index, belief.probes) == (0, 0)


def test_a_yaw_exact_goal_counts_a_full_turn_and_the_table_is_the_workspace_and_margin():
    belief = Belief()
    plan = two_action_plan()
    belief.adopt(plan)
    assert belief.turn_period == GRASP_SYMMETRY
    goal = dataclasses.replace(plan.scene.goal, yaw_exact=True)
    belief.adopt(dataclasses.replace(plan, scene=dataclasses.replace(plan.scene, goal=goal)))
    assert belief.turn_period == 2 * math.pi
    margin = table_margin_of(plan.params)
    assert belief.table() == WS.grown(margin)
