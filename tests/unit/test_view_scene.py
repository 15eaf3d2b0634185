"""densepack-view's 3-D scene (Foxglove SceneUpdate entities), read back from the bytes the
app receives: each entity in the frame its message names, cubes where the blocks are, the
goal's slots outlined where the goal puts them, arrows along the plan."""

from __future__ import annotations

import math

import numpy as np
import pytest
from foxglove.messages import SceneUpdate
from scipy.spatial.transform import Rotation

from msgs_py import BlockSet, Plan, load_scene
from msgs_py.actions import PickPlace, Push
from msgs_py.poses import BlockPose, Pose2D
from nodes.common.paths import config_path
from nodes.tools import view_scene
from tests.unit.foxglove_wire import decode

S = 0.0508


def received(*entities) -> list[dict]:
    """The entities as the app decodes them."""
    return decode(SceneUpdate, view_scene.scene_update(entities).encode())["entities"]


def xyz(vector: dict) -> tuple[float, float, float]:
    return vector["x"], vector["y"], vector["z"]


def yaw_of(orientation: dict) -> float:
    q = [orientation[k] for k in "xyzw"]
    return Rotation.from_quat(q).as_euler("xyz")[2]


def test_block_cubes_stand_on_the_table_at_the_detected_poses():
    blocks = BlockSet((BlockPose(3, 0.6, -0.1, 0.3), BlockPose(7, 0.7, 0.05, 0.0)), block_size=S)
    (entity,) = received(view_scene.block_entity(blocks, 1_500_000_000), None)
    assert (entity["id"], entity["frame_id"], entity["frame_locked"]) == ("blocks", "world", True)
    assert entity["timestamp"] == {"seconds": 1, "nanos": 500_000_000}
    for cube, text, block in zip(entity["cubes"], entity["texts"], blocks.blocks, strict=True):
        assert np.allclose(xyz(cube["pose"]["position"]), (block.pose.x, block.pose.y, S / 2))
        assert yaw_of(cube["pose"]["orientation"]) == pytest.approx(block.pose.theta)
        assert np.allclose(xyz(cube["size"]), (S, S, S))
        assert text["text"] == str(block.id)


@pytest.mark.parametrize("frame_id, drawn_in", [("world", "world"), ("", "world"),
                                                ("camera_optical_frame", "camera_optical_frame")])
def test_each_entity_is_in_the_frame_its_message_names(frame_id, drawn_in):
    """A detection or TCP pose in another frame is not drawn as if it were in world."""
    blocks = BlockSet((BlockPose(1, 0.1, 0.2, 0.0),), frame_id=frame_id, block_size=S)
    tcp = view_scene.tcp_entity((0.25, -0.55, 0.40), (1.0, 0.0, 0.0, 0.0), 0, frame_id)
    frames = [e["frame_id"] for e in received(view_scene.block_entity(blocks, 0), tcp)]
    assert frames == [drawn_in, drawn_in]


def test_goal_slots_are_outlined_where_the_goal_puts_them_and_named_by_block():
    layout = load_scene(config_path("scenes/default.yaml"))
    slots = layout.goal.slot_poses(S)
    (unnamed,) = received(view_scene.goal_entity(layout, 0))
    (named,) = received(view_scene.goal_entity(layout, 0, block_ids=[8, 0, 3, 1, 2, 4, 5, 6, 7]))
    assert named["frame_id"] == "world" and len(named["lines"]) == len(slots) == 9
    for tile, outline, slot in zip(named["cubes"], named["lines"], slots, strict=True):
        for pose in (tile["pose"], outline["pose"]):
            assert np.allclose(xyz(pose["position"])[:2], (slot.x, slot.y))
            assert yaw_of(pose["orientation"]) == pytest.approx(slot.theta)
        corners = np.array([xyz(p) for p in outline["points"]])
        assert len(corners) == 24  # 12 edges, a point pair each
        assert np.allclose(corners.min(axis=0), (-S / 2, -S / 2, 0.0))
        assert np.allclose(corners.max(axis=0), (S / 2, S / 2, S))
    # a labeled grid: slot k is the k-th smallest block id, once the ids are known
    assert [t["text"] for t in named["texts"]] == [f"goal {k}" for k in range(9)]
    assert [t["text"] for t in unnamed["texts"]] == [f"slot {k}" for k in range(9)]


def test_slot_names_of_explicit_and_unlabeled_goals():
    layout = load_scene(config_path("scenes/default.yaml"))
    grid = layout.goal
    assert view_scene.slot_names(grid, [12, 10, 11], S)[:4] == ["goal 10", "goal 11", "goal 12",
                                                                "slot 3"]
    unlabeled = type(grid)(grid=grid.grid, labeled=False)
    assert view_scene.slot_names(unlabeled, [0, 1], S)[:2] == ["slot 0", "slot 1"]


def test_plan_arrows_run_from_each_block_to_its_target_until_done():
    plan = Plan(actions=(
        PickPlace(0, Pose2D(0.52, -0.27, 0.35), Pose2D(0.70, 0.0, 0.0)),
        Push(1, Pose2D(0.6, 0.1, 0.0), Pose2D(0.65, 0.1, 0.0), (1.0, 0.0), 0.05),
        PickPlace(2, Pose2D(0.8, 0.2, 0.0), Pose2D(0.8, 0.2, math.pi / 2)),  # turn in place
    ), plan_id="p")
    (all_ahead,) = received(view_scene.plan_entity(plan, 0))
    (after_one,) = received(view_scene.plan_entity(plan, 0, done=1))
    assert len(all_ahead["arrows"]) == 2 and len(after_one["arrows"]) == 1  # no turn arrow
    for arrow, action in zip(all_ahead["arrows"], plan.actions, strict=False):
        start = np.array(xyz(arrow["pose"]["position"]))
        end = np.array([action.to.x, action.to.y])
        length = arrow["shaft_length"] + arrow["head_length"]
        heading = yaw_of(arrow["pose"]["orientation"])
        tip = start[:2] + length * np.array([math.cos(heading), math.sin(heading)])
        assert np.allclose(start[:2], (action.from_.x, action.from_.y))
        assert np.allclose(tip, end, atol=1e-9)
        assert start[2] > S  # above the blocks, not hidden in them


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
    (tcp,) = received(view_scene.tcp_entity((0.25, -0.55, 0.40), tool_q, 0))
    assert np.allclose(xyz(tcp["spheres"][0]["pose"]["position"]), (0.25, -0.55, 0.40))
    sent = [tcp["arrows"][0]["pose"]["orientation"][k] for k in "xyzw"]
    assert np.allclose(Rotation.from_quat(sent).apply([1.0, 0.0, 0.0]), expected, atol=1e-6)


def test_arrows_point_along_any_direction():
    rng = np.random.default_rng(1)
    for d in rng.normal(size=(50, 3)):
        d /= np.linalg.norm(d)
        q = view_scene.pointing_quaternion(d)
        assert np.allclose(Rotation.from_quat(q).apply([1.0, 0.0, 0.0]), d, atol=1e-9)
