"""Plans and actions: JSON round trips and refusals; statuses refuse unknown states (their
message codecs are tested in ros/test_codecs)."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from msgs_py import (
    ExecutorStatus,
    MessageError,
    PickPlace,
    Plan,
    PlannerStatus,
    Pose2D,
    Push,
    Scene,
    action_from_dict,
    load_plan,
    save_plan,
)
from msgs_py.documents import dump_json

coords = st.floats(-2.0, 2.0, allow_nan=False)
angles = st.floats(-math.pi, math.pi, allow_nan=False)
poses = st.builds(Pose2D, coords, coords, angles)


@st.composite
def pushes(draw):
    start = draw(poses)
    heading = draw(angles)
    distance = draw(st.floats(1e-3, 0.5))
    end = Pose2D(start.x + math.cos(heading) * distance, start.y + math.sin(heading) * distance,
                 start.theta)
    return Push.between(draw(st.integers(0, 586)), start, end)


actions = st.one_of(
    st.builds(PickPlace, st.integers(0, 586), poses, poses, st.sampled_from([0, 1])), pushes()
)
params = st.dictionaries(
    st.text("abcdefgh_", min_size=1, max_size=8),
    st.one_of(st.floats(-1e3, 1e3), st.integers(-100, 100), st.booleans(), st.text(max_size=5)),
    max_size=6,
)
plans = st.builds(
    Plan,
    actions=st.lists(actions, max_size=8).map(tuple),
    planner=st.sampled_from(["pirs", "rpg"]),
    params=params,
    seed=st.integers(0, 2**31),
    planning_time_s=st.floats(0, 100),
    cost=st.floats(-10, 1e4),
    plan_id=st.text("0123456789abcdef", max_size=12),
)


@given(plans)
def test_plan_round_trips_through_json(plan):
    assert Plan.from_dict(json.loads(dump_json(plan.to_dict()))) == plan


def test_plan_file_with_scene_round_trips(tmp_path):
    scene = Scene.from_dict({
        "version": 1,
        "workspace": {"x_min": 0.4, "x_max": 1.0, "y_min": -0.4, "y_max": 0.4},
        "blocks": [{"id": 3, "x": 0.5, "y": 0.0}],
        "goal": {"poses": [{"id": 3, "x": 0.7, "y": 0.1}]},
    })
    plan = Plan((PickPlace(3, Pose2D(0.5, 0.0), Pose2D(0.7, 0.1), 1),), scene=scene,
                params={"a1": 1.0, "n_samples": 200})
    assert load_plan(save_plan(plan, tmp_path / "p.json")) == plan


# --- refusals ------------------------------------------------------------------------------------
def test_push_must_keep_its_yaw_and_follow_its_direction():
    with pytest.raises(MessageError, match="direction"):
        Push(0, Pose2D(0, 0), Pose2D(0.1, 0), (0.6, 0.6), 0.1)
    with pytest.raises(MessageError, match=r"from \+ direction"):
        Push(0, Pose2D(0, 0), Pose2D(0.2, 0), (1.0, 0.0), 0.1)
    with pytest.raises(MessageError, match="yaw"):
        Push(0, Pose2D(0, 0), Pose2D(0.1, 0, 0.2), (1.0, 0.0), 0.1)


def test_bad_grasp_is_refused_with_its_field():
    data = {"type": "pick_place", "block": 1, "from": {"x": 0, "y": 0}, "to": {"x": 1, "y": 0},
            "grasp": 2}
    with pytest.raises(MessageError) as err:
        action_from_dict(data, "actions[4]")
    assert err.value.field == "actions[4].grasp"


def test_unknown_action_type_is_refused():
    with pytest.raises(MessageError, match=r"actions\[0\]\.type"):
        Plan.from_dict({"version": 1, "actions": [{"type": "throw", "block": 0}]})


def test_non_finite_plan_numbers_are_refused():
    doc = {"version": 1, "actions": [], "params": {"a1": float("nan")}}
    with pytest.raises(MessageError, match=r"params\.a1"):
        Plan.from_dict(doc)
    doc = {"version": 1, "actions": [{"type": "pick_place", "block": 0,
                                      "from": {"x": float("inf"), "y": 0}, "to": {"x": 0, "y": 0}}]}
    with pytest.raises(MessageError, match=r"actions\[0\]\.from\.x"):
        Plan.from_dict(doc)


def test_wrong_plan_version_and_unknown_fields_are_refused():
    with pytest.raises(MessageError, match="version"):
        Plan.from_dict({"version": 0, "actions": []})
    with pytest.raises(MessageError, match="unknown field"):
        Plan.from_dict({"version": 1, "actions": [], "eta": 3})


def test_unknown_states_are_refused():
    with pytest.raises(MessageError, match="state"):
        ExecutorStatus("dancing")
    with pytest.raises(MessageError, match="state"):
        PlannerStatus("thinking")
