"""densepack-view's layout file holds the structure the apps require of a layout they import
(Lichtblick's importer checks the top-level fields; its mosaic looks each leaf id up in
``configById`` and builds the panel named before the ``!``), names only topics the cell
publishes, and points the 3-D camera at the workspace."""

from __future__ import annotations

import json
import re

import pytest

from msgs_py import load_scene
from nodes.common.paths import config_path
from nodes.tools import view_layout
from tests.helpers import REPO

#: The panel types the app builds (Lichtblick's panel list; the Foxglove app has these too).
APP_PANEL_TYPES = {
    "3D", "DiagnosticStatusPanel", "DiagnosticSummary", "Image", "Indicator", "Gauge", "Teleop",
    "map", "Parameters", "Plot", "PieChart", "Publish", "CallService", "RawMessages",
    "RawMessagesVirtual", "RosOut", "StateTransitions", "Table", "TopicGraph", "SourceInfo",
    "GlobalVariableSliderPanel", "NodePlayground", "Tab", "PlaybackPerformance"}


def layout_problems(doc: object) -> list[str]:
    """What the app would reject or fail to draw in a layout document (empty: none)."""
    if not isinstance(doc, dict):
        return ["a layout is a JSON object"]
    problems = [f"missing or invalid {key!r}" for key in ("configById", "globalVariables")
                if not isinstance(doc.get(key), dict)]
    playback = doc.get("playbackConfig")
    if not isinstance(playback, dict) or not isinstance(playback.get("speed"), int | float):
        problems.append("missing or invalid 'playbackConfig' (needs a numeric 'speed')")
    if problems:
        return problems
    leaves = _mosaic_leaves(doc.get("layout"), problems)
    configs = doc["configById"]
    problems += [f"mosaic names {pid!r}, which configById lacks" for pid in leaves
                 if pid not in configs]
    problems += [f"configById holds {pid!r}, which the mosaic does not place" for pid in configs
                 if pid not in leaves]
    problems += [f"panel {pid!r}: the app has no panel type {pid.split('!')[0]!r}"
                 for pid in configs if pid.split("!")[0] not in APP_PANEL_TYPES]
    return problems


def _mosaic_leaves(node: object, problems: list[str]) -> list[str]:
    if isinstance(node, str):
        return [node]
    if not isinstance(node, dict) or not {"first", "second", "direction"} <= node.keys():
        problems.append(f"a mosaic node is a panel id or {{first, second, direction}}: {node}")
        return []
    if node["direction"] not in ("row", "column"):
        problems.append(f"mosaic direction {node['direction']!r} is not row or column")
    if not 0 < node.get("splitPercentage", 50) < 100:
        problems.append(f"splitPercentage {node['splitPercentage']} is not in (0, 100)")
    return _mosaic_leaves(node["first"], problems) + _mosaic_leaves(node["second"], problems)


def named_topics(node: object) -> set[str]:
    """Every topic a layout names: keys and strings starting with '/', a message path's
    topic part (``/executor/status.state`` -> ``/executor/status``)."""
    if isinstance(node, dict):
        return {t for k, v in node.items() for t in named_topics(k) | named_topics(v)}
    if isinstance(node, list):
        return {t for item in node for t in named_topics(item)}
    if isinstance(node, str) and node.startswith("/"):
        return {node.split(".")[0]}
    return set()


def contract_topics() -> set[str]:
    """The topics of docs/contracts.md's table (the interface's one home)."""
    text = (REPO / "docs" / "contracts.md").read_text()
    return {name for row in re.findall(r"^\| (.*?) \|", text, re.M)
            for name in re.findall(r"`(/[\w/]+)`", row)}


LAYOUT = json.loads(view_layout.layout_json())


def test_the_layout_file_in_the_repo_is_the_generated_one():
    committed = config_path(view_layout.LAYOUT_FILE).read_text()
    assert committed == view_layout.layout_json(), "run densepack-view --write-layout"


def test_the_layout_has_the_structure_the_app_imports():
    assert layout_problems(LAYOUT) == []
    kinds = {pid.split("!")[0] for pid in LAYOUT["configById"]}
    assert kinds == {"3D", "Image", "StateTransitions", "RawMessages"}


def test_the_sdk_tree_format_is_what_the_app_rejects():
    """The checker tells the old file (``foxglove.layouts``' ``{version, content}`` tree)
    from one the app imports."""
    sdk_tree = {"version": 1, "content": {"type": "split", "direction": "row", "items": [
        {"proportion": 1, "content": {"type": "panel", "panelType": "ThreeDee"}}]}}
    assert layout_problems(sdk_tree)[:2] == ["missing or invalid 'configById'",
                                             "missing or invalid 'globalVariables'"]
    broken = json.loads(json.dumps(LAYOUT))
    broken["layout"]["first"] = "3D!elsewhere"
    broken["configById"]["Gauge!x"] = {}
    assert layout_problems(broken) == [
        "mosaic names '3D!elsewhere', which configById lacks",
        "configById holds '3D!cell', which the mosaic does not place",
        "configById holds 'Gauge!x', which the mosaic does not place"]


def test_every_topic_the_layout_names_is_one_the_cell_or_the_view_publishes():
    topics = named_topics(LAYOUT["configById"])
    assert {view_layout.SCENE_TOPIC, view_layout.CAMERA_TOPIC, view_layout.STATUS_TOPIC} <= topics
    unknown = topics - contract_topics() - {view_layout.SCENE_TOPIC}
    assert not unknown, f"the layout names topics no node publishes: {unknown}"


def test_the_3d_camera_orbits_the_workspace_centre():
    """The app orbits ``targetOffset`` (``target`` it keeps but does not use): a target left
    at the origin puts the arm's base, not the blocks, in the middle of the view."""
    camera = LAYOUT["configById"]["3D!cell"]["cameraState"]
    ws = load_scene(config_path(view_layout.VIEW_SCENE_FILE)).workspace
    x, y, z = camera["targetOffset"]
    assert (x, y, z) == ((ws.x_min + ws.x_max) / 2, (ws.y_min + ws.y_max) / 2, 0.0)
    assert LAYOUT["configById"]["3D!cell"]["followTf"] == "world"


def test_panel_titles_and_checks():
    for config in LAYOUT["configById"].values():
        assert all(config[key] for key in view_layout.TITLE_KEYS)
    panel = view_layout.Panel("Plot", "a", "a plot")
    with pytest.raises(ValueError, match="unique"):
        view_layout.layout_data(view_layout.Split("row", panel, panel))
    with pytest.raises(ValueError, match="first_percent"):
        view_layout.Split("row", panel, view_layout.Panel("Plot", "b", "b"), 100.0)
