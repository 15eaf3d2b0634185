"""Scene and goal documents: round trips and one test per kind of bad input."""

from __future__ import annotations

import copy
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from msgs_py import (
    BlockPose,
    Goal,
    GoalSlot,
    GridSpec,
    MessageError,
    Scene,
    Workspace,
    load_scene,
    save_scene,
)
from msgs_py.documents import parse_text

WS = {"x_min": 0.45, "x_max": 0.95, "y_min": -0.35, "y_max": 0.35}
S = 0.0508


def scene_doc(**overrides):
    doc = {
        "version": 1,
        "workspace": dict(WS),
        "block_size": S,
        "blocks": [
            {"id": 0, "x": 0.55, "y": -0.2, "theta": 0.1},
            {"id": 1, "x": 0.70, "y": 0.2, "theta": -0.3},
            {"id": 2, "x": 0.85, "y": 0.0, "theta": 0.0},
        ],
        "goal": {"poses": [
            {"id": 0, "x": 0.64, "y": 0.0, "theta": 0.0},
            {"id": 1, "x": 0.70, "y": 0.0, "theta": 0.0},
        ]},
        "labeled": True,
    }
    doc.update(overrides)
    return doc


# --- round trips ---------------------------------------------------------------------------------
@st.composite
def scenes(draw):
    """Random valid scenes: blocks on a coarse lattice (never overlapping), optional goal."""
    cells = draw(st.lists(st.integers(0, 19), unique=True, max_size=12))
    ids = draw(st.lists(st.integers(0, 586), unique=True, min_size=len(cells),
                        max_size=len(cells)))
    blocks = []
    for block_id, cell in zip(ids, cells, strict=True):
        r, c = divmod(cell, 5)
        blocks.append(BlockPose(
            id=block_id,
            x=0.4 + 0.1 * c + draw(st.floats(-0.01, 0.01)),
            y=-0.4 + 0.1 * r + draw(st.floats(-0.01, 0.01)),
            theta=draw(st.floats(-math.pi, math.pi)),
        ))
    goal = None
    if blocks and draw(st.booleans()):
        n = draw(st.integers(1, min(3, len(blocks))))
        goal = Goal(grid=GridSpec(1, n, (0.7, 0.3), draw(st.floats(-0.3, 0.3)),
                                  draw(st.floats(0.0, 0.01))),
                    labeled=draw(st.booleans()), yaw_exact=draw(st.booleans()))
    return Scene(Workspace(0.3, 1.0, -0.5, 0.5), S, tuple(blocks), goal)


@given(scenes())
def test_scene_round_trips_through_dict_yaml_and_json(scene):
    assert Scene.from_dict(scene.to_dict()) == scene
    assert Scene.from_dict(parse_text(__import__("yaml").safe_dump(scene.to_dict()))) == scene
    assert Scene.from_dict(parse_text(__import__("json").dumps(scene.to_dict()))) == scene


def test_scene_files_round_trip(tmp_path):
    scene = Scene.from_dict(scene_doc())
    for name in ("s.yaml", "s.json"):
        assert load_scene(save_scene(scene, tmp_path / name)) == scene


def test_default_scene_file_is_valid_and_dense():
    from nodes.common.paths import config_path

    scene = load_scene(config_path("scenes/default.yaml"))
    assert len(scene.blocks) == 9 and scene.goal.grid.rows == scene.goal.grid.cols == 3
    assert scene.goal.grid.gap == pytest.approx(0.003)


# --- grids ----------------------------------------------------------------------------------------
def test_grid_slots_are_row_major_from_the_minus_x_minus_y_corner():
    grid = GridSpec(rows=2, cols=3, center=(0.7, 0.0), theta=0.0, gap=0.002)
    slots = grid.slot_poses(S)
    pitch = S + 0.002
    assert slots[0].x == pytest.approx(0.7 - pitch) and slots[0].y == pytest.approx(-pitch / 2)
    assert slots[1].x == pytest.approx(0.7) and slots[1].y == pytest.approx(-pitch / 2)
    assert slots[3].x == pytest.approx(0.7 - pitch) and slots[3].y == pytest.approx(pitch / 2)


def test_grid_rotation_turns_the_slots_about_the_centre():
    grid = GridSpec(rows=1, cols=2, center=(0.7, 0.0), theta=math.pi / 2, gap=0.0)
    a, b = grid.slot_poses(S)
    assert a.x == pytest.approx(0.7) and a.y == pytest.approx(-S / 2)
    assert b.y == pytest.approx(S / 2) and b.theta == pytest.approx(math.pi / 2)


def test_labeled_grid_assigns_slots_by_increasing_block_id():
    doc = scene_doc(goal={"grid": {"rows": 1, "cols": 3, "center": [0.7, 0.0], "gap": 0.003}})
    doc["blocks"][0]["id"] = 9
    scene = Scene.from_dict(doc)
    assignment = scene.goal_assignment()
    assert list(assignment) == [1, 2, 9]
    assert assignment[1].x < assignment[2].x < assignment[9].x


def test_touching_blocks_do_not_count_as_overlapping():
    doc = scene_doc(goal={"grid": {"rows": 1, "cols": 3, "center": [0.7, 0.0], "gap": 0.0}})
    Scene.from_dict(doc)  # zero gap: touching slots are fine


def test_retrieval_goal_fixes_only_some_blocks():
    doc = scene_doc(goal={"poses": [{"id": 2, "x": 0.5, "y": 0.3}]})
    assert Scene.from_dict(doc).goal_assignment().keys() == {2}


# --- bad input: each names the field and the value ------------------------------------------------
def expect_error(doc, field, fragment=""):
    with pytest.raises(MessageError) as err:
        Scene.from_dict(doc)
    assert err.value.field == field, str(err.value)
    assert fragment in str(err.value)
    return err.value


def test_overlapping_start_blocks_are_refused():
    doc = scene_doc()
    doc["blocks"][1].update(x=0.56, y=-0.19)
    expect_error(doc, "blocks[1]", "overlaps blocks[0]")


def test_goal_slot_outside_the_workspace_is_refused():
    doc = scene_doc()
    doc["goal"]["poses"][1]["x"] = 0.94
    expect_error(doc, "goal.poses[1]", "leaves the workspace")


def test_grid_goal_outside_the_workspace_is_refused():
    doc = scene_doc(goal={"grid": {"rows": 3, "cols": 3, "center": [0.93, 0.0]}})
    doc["blocks"].extend({"id": 10 + k, "x": 0.5 + 0.06 * k, "y": 0.3} for k in range(6))
    expect_error(doc, "goal.grid[1]", "leaves the workspace")


def test_overlapping_goal_slots_are_refused():
    doc = scene_doc()
    doc["goal"]["poses"][1]["x"] = 0.66
    expect_error(doc, "goal.poses[1]", "overlaps goal slot 0")


def test_duplicate_block_ids_are_refused():
    doc = scene_doc()
    doc["blocks"][2]["id"] = 0
    expect_error(doc, "blocks[2].id", "duplicate")


def test_duplicate_goal_ids_are_refused():
    doc = scene_doc()
    doc["goal"]["poses"][1]["id"] = 0
    expect_error(doc, "goal.poses[1].id", "duplicate")


def test_unknown_goal_id_is_refused():
    doc = scene_doc()
    doc["goal"]["poses"][1]["id"] = 42
    err = expect_error(doc, "goal.poses[1].id", "unknown block id")
    assert err.value == 42


def test_more_goal_slots_than_blocks_is_refused():
    doc = scene_doc(goal={"grid": {"rows": 2, "cols": 2, "center": [0.7, 0.0]}})
    expect_error(doc, "goal.grid", "more goal slots than blocks")


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_numbers_are_refused(bad):
    doc = scene_doc()
    doc["blocks"][1]["y"] = bad
    expect_error(doc, "blocks[1].y", "finite")


def test_nan_in_yaml_text_is_refused():
    text = "version: 1\nworkspace: {x_min: .nan, x_max: 1, y_min: 0, y_max: 1}\n"
    with pytest.raises(MessageError, match=r"workspace\.x_min"):
        Scene.from_dict(parse_text(text))


def test_unknown_fields_are_refused():
    doc = scene_doc()
    doc["blocks"][0]["colour"] = "red"
    expect_error(doc, "blocks[0].colour", "unknown field")
    expect_error(scene_doc(speed=3), "speed", "unknown field")


def test_wrong_version_is_refused():
    expect_error(scene_doc(version=2), "version", "unsupported")


def test_unlabeled_goal_with_ids_is_refused():
    expect_error(scene_doc(labeled=False), "goal.poses[0].id", "unlabeled")


def test_block_outside_the_workspace_is_refused():
    doc = scene_doc()
    doc["blocks"][0]["x"] = 0.46
    expect_error(doc, "blocks[0]", "leaves the workspace")


def test_inverted_workspace_is_refused():
    doc = scene_doc(workspace=dict(WS, x_max=0.4))
    expect_error(doc, "workspace.x_max", "must exceed")


def test_goal_with_both_poses_and_grid_is_refused():
    doc = scene_doc()
    doc["goal"]["grid"] = {"rows": 1, "cols": 1, "center": [0.7, 0]}
    expect_error(doc, "goal", "exactly one")


def test_nothing_is_half_applied_on_error():
    scene = Scene.from_dict(scene_doc())
    before = copy.deepcopy(scene)
    moved = [b for b in scene.blocks]
    moved[0] = BlockPose(0, moved[1].x, moved[1].y)
    with pytest.raises(MessageError):
        scene.with_blocks(moved)
    assert scene == before


def test_goal_layout_without_blocks_defers_id_checks():
    layout = Scene.from_dict(scene_doc(blocks=[]))
    blocks = Scene.from_dict(scene_doc()).blocks
    assert layout.with_blocks(blocks).goal_assignment().keys() == {0, 1}
    with pytest.raises(MessageError, match="unknown block id"):
        layout.with_blocks(blocks[1:])


def test_slot_without_id_in_a_labeled_goal_is_refused():
    with pytest.raises(MessageError, match="names a block"):
        Goal(slots=(GoalSlot(0.7, 0.0),), labeled=True)


def test_unreadable_file_names_the_path(tmp_path):
    with pytest.raises(MessageError, match="cannot read file"):
        load_scene(tmp_path / "nope.yaml")


def test_malformed_yaml_is_refused(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("version: 1\nworkspace: {x_min: [\n")
    with pytest.raises(MessageError, match="not valid YAML/JSON"):
        load_scene(path)
