"""densepack-view's 3-D scene (Foxglove SceneUpdate entities) and its layout file."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from foxglove.messages import SceneUpdate
from scipy.spatial.transform import Rotation

from msgs_py import BlockSet, Plan, load_scene
from msgs_py.actions import PickPlace, Push
from msgs_py.poses import BlockPose, Pose2D
from nodes.common.paths import config_path
from nodes.tools import view_layout, view_scene

S = 0.0508


def test_blocks_are_cubes_standing_on_the_table():
    blocks = BlockSet((BlockPose(3, 0.6, -0.1, 0.3), BlockPose(7, 0.7, 0.05, 0.0)), block_size=S)
    entity = view_scene.block_entity(blocks, 1_500_000_000)
    update = view_scene.scene_update([entity, None])
    assert isinstance(update, SceneUpdate) and update.encode()  # a valid protobuf message
    data = update.encode()
    for text in (b"blocks", b"world", b"3", b"7"):
        assert text in data


def test_goal_slots_plan_arrows_and_tcp_encode():
    layout = load_scene(config_path("scenes/default.yaml"))
    goal = view_scene.goal_entity(layout, 0)
    plan = Plan(actions=(
        PickPlace(0, Pose2D(0.52, -0.27, 0.35), Pose2D(0.70, 0.0, 0.0)),
        Push(1, Pose2D(0.6, 0.1, 0.0), Pose2D(0.65, 0.1, 0.0), (1.0, 0.0), 0.05),
        PickPlace(2, Pose2D(0.8, 0.2, 0.0), Pose2D(0.8, 0.2, math.pi / 2)),  # turn in place
    ), plan_id="p")
    arrows = view_scene.plan_entity(plan, 0)
    ahead = view_scene.plan_entity(plan, 0, done=1)
    tcp = view_scene.tcp_entity((0.25, -0.55, 0.40), (1.0, 0.0, 0.0, 0.0), 0)  # tool down
    sizes = [len(view_scene.scene_update([e]).encode()) for e in (goal, arrows, ahead, tcp)]
    # 9 goal tiles with labels; 2 arrows then 1 (no arrow for a turn in place)
    assert sizes[0] > 9 * 40 and sizes[1] > sizes[2] > 0 and sizes[3] > 0


@pytest.mark.parametrize("tool_q, expected", [
    ((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, -1.0)),  # tool down: 180 degrees about x
    ((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0)),
    ((0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5)), (1.0, 0.0, 0.0)),  # 90 degrees about y
])
def test_the_tcp_arrow_points_where_the_tool_does(tool_q, expected):
    z_axis = view_scene.tool_z_axis(tool_q)
    assert np.allclose(z_axis, expected, atol=1e-12)
    x, y, z, w = view_scene.pointing_quaternion(z_axis)
    rotation = Rotation.from_quat([x, y, z, w])  # scipy: (x, y, z, w) too
    assert np.allclose(rotation.apply([1.0, 0.0, 0.0]), expected, atol=1e-9)


def test_arrows_point_along_any_direction():
    rng = np.random.default_rng(1)
    for d in rng.normal(size=(50, 3)):
        d /= np.linalg.norm(d)
        q = view_scene.pointing_quaternion(d)
        assert np.allclose(Rotation.from_quat(q).apply([1.0, 0.0, 0.0]), d, atol=1e-9)


def test_the_layout_file_in_the_repo_is_the_generated_one():
    committed = config_path(view_layout.LAYOUT_FILE).read_text()
    assert committed == view_layout.layout_json(), "run densepack-view --write-layout"
    doc = json.loads(committed)
    text = json.dumps(doc)
    for topic in (view_layout.SCENE_TOPIC, view_layout.CAMERA_TOPIC, view_layout.STATUS_TOPIC):
        assert topic in text
    kinds = {p["panelType"] for p in _panels(doc["content"])}
    assert kinds == {"ThreeDee", "Image", "StateTransitions", "RawMessages"}


def _panels(node: dict) -> list[dict]:
    if node.get("type") == "panel":
        return [node]
    return [p for item in node.get("items", []) for p in _panels(item["content"])]
