"""The Foxglove layout of ``densepack-view`` (``config/foxglove/densepack-layout.json``), in
the layout format the apps read: what Lichtblick and the Foxglove app export and import
(*Import layout*, or Lichtblick's ``layoutUrl``). Panels are kept by id in ``configById``
(an id is ``<panel type>!<key>``), a mosaic tree of those ids (``layout``: binary splits with
the first child's share in per cent) places them, and ``globalVariables``,
``playbackConfig`` and ``userNodes`` come beside.

Why our own dataclasses and not ``foxglove.layouts``: the SDK writes the Foxglove cloud's
newer ``{version, content: {type: "split", items}}`` tree with ``panelType`` names
(``ThreeDee``), which Lichtblick's importer rejects (it requires ``configById``,
``globalVariables`` and ``playbackConfig.speed``) and the Foxglove app's file import does not
read either.

Left, the 3-D scene in ``world`` (``/view/scene``: detected blocks, goal slots, the plan's
arrows, the TCP; the detector's and the plan's MarkerArrays off by default, one toggle away),
looking at the default scene's workspace; right, the overhead camera
(``/camera/image_raw/compressed``) above the executor's state over time and its latest
``/executor/status`` message, decoded with its ``ros2msg`` schema (states by name).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from msgs_py import load_scene
from nodes.common.paths import config_path

#: The repository's layout file (config/).
LAYOUT_FILE = "foxglove/densepack-layout.json"
SCENE_TOPIC = "/view/scene"
CAMERA_TOPIC = "/camera/image_raw/compressed"
CAMERA_INFO_TOPIC = "/camera/camera_info"
STATUS_TOPIC = "/executor/status"
TCP_TOPIC = "/tcp_pose"
#: MarkerArrays the nodes publish: listed in the 3-D panel, hidden (the scene draws the same).
MARKER_TOPICS = ("/blocks/detected/markers", "/plan/markers", "/sim/ground_truth/markers")
#: The scene whose workspace the 3-D camera looks at.
VIEW_SCENE_FILE = "scenes/default.yaml"
#: Config keys the apps read a panel's title from (Lichtblick's, the Foxglove app's).
TITLE_KEYS = ("lichtblickPanelTitle", "foxglovePanelTitle")
#: 3-D camera: orbit distance (m), polar angle from +z and azimuth (degrees), field of view.
#: Azimuth 90: seen from the arm's base, +x up the screen and +y to the left, as the overhead
#: camera's image shows the table.
CAMERA_DISTANCE_M = 1.0
CAMERA_PHI_DEG = 45.0
CAMERA_THETA_DEG = 90.0
CAMERA_FOVY_DEG = 45.0
#: The table grid layer: its id, side and cell (m).
TABLE_GRID_ID = "table-grid"
TABLE_GRID_SIZE_M = 1.0
TABLE_GRID_M = 0.1


@dataclass(frozen=True, slots=True)
class Panel:
    """One panel: its app type (``3D``, ``Image``, ...), a key unique in the layout, its
    title and its config as the app stores it."""

    kind: str
    key: str
    title: str
    config: dict[str, Any] = field(default_factory=dict)

    @property
    def panel_id(self) -> str:
        return f"{self.kind}!{self.key}"

    def saved_config(self) -> dict[str, Any]:
        return {**self.config, **{key: self.title for key in TITLE_KEYS}}


@dataclass(frozen=True, slots=True)
class Split:
    """Two parts side by side (``row``) or stacked (``column``); ``first_percent`` is the
    first part's share."""

    direction: Literal["row", "column"]
    first: Panel | Split
    second: Panel | Split
    first_percent: float = 50.0

    def __post_init__(self) -> None:
        if not 0.0 < self.first_percent < 100.0:
            raise ValueError(f"Split.first_percent must be in (0, 100), not {self.first_percent}")


def mosaic(node: Panel | Split) -> str | dict[str, Any]:
    """The app's mosaic tree: a panel id, or ``{first, second, direction, splitPercentage}``."""
    if isinstance(node, Panel):
        return node.panel_id
    return {"first": mosaic(node.first), "second": mosaic(node.second),
            "direction": node.direction, "splitPercentage": node.first_percent}


def panels_of(node: Panel | Split) -> list[Panel]:
    """The panels of a tree, first to last."""
    if isinstance(node, Panel):
        return [node]
    return [*panels_of(node.first), *panels_of(node.second)]


def layout_data(root: Panel | Split) -> dict[str, Any]:
    """The layout as the apps store it (Lichtblick's ``LayoutData``).

    Raises:
        ValueError: two panels share an id (the mosaic could not tell them apart).
    """
    found = panels_of(root)
    ids = [p.panel_id for p in found]
    if len(set(ids)) != len(ids):
        raise ValueError(f"panel ids must be unique: {ids}")
    return {"configById": {p.panel_id: p.saved_config() for p in found},
            "globalVariables": {}, "userNodes": {}, "playbackConfig": {"speed": 1.0},
            "layout": mosaic(root)}


def view_target() -> tuple[float, float, float]:
    """The 3-D camera's orbit centre (m, ``world``): the view scene's workspace centre."""
    ws = load_scene(config_path(VIEW_SCENE_FILE)).workspace
    return ((ws.x_min + ws.x_max) / 2, (ws.y_min + ws.y_max) / 2, 0.0)


def scene_panel() -> Panel:
    """The 3-D panel. The camera orbits ``targetOffset`` in the followed frame (``target`` is
    a field the app keeps but does not use for the orbit); ``followMode`` ``follow-none``
    leaves it fixed in ``world``, which is where every entity is."""
    topics: dict[str, Any] = {SCENE_TOPIC: {"visible": True},
                              TCP_TOPIC: {"visible": False}}
    topics.update({topic: {"visible": False} for topic in MARKER_TOPICS})
    return Panel("3D", "cell", "cell (world)", {
        "followTf": "world", "followMode": "follow-none",
        "cameraState": {"distance": CAMERA_DISTANCE_M, "perspective": True,
                        "phi": CAMERA_PHI_DEG, "thetaOffset": CAMERA_THETA_DEG,
                        "target": [0.0, 0.0, 0.0], "targetOffset": list(view_target()),
                        "targetOrientation": [0.0, 0.0, 0.0, 1.0],
                        "fovy": CAMERA_FOVY_DEG, "near": 0.01, "far": 50.0},
        "scene": {"transforms": {"showLabel": False, "axisScale": 0.3}},
        "topics": topics, "layers": {TABLE_GRID_ID: table_grid()}, "transforms": {}})


def table_grid() -> dict[str, Any]:
    """A grid on the table top under the workspace (``TABLE_GRID_M`` cells) for scale."""
    return {"visible": True, "frameLocked": True, "label": "table (10 cm grid)",
            "instanceId": TABLE_GRID_ID, "layerId": "foxglove.Grid", "frameId": "world",
            "size": TABLE_GRID_SIZE_M, "divisions": round(TABLE_GRID_SIZE_M / TABLE_GRID_M),
            "lineWidth": 1.0, "color": "#a0a0a0", "position": list(view_target()),
            "rotation": [0.0, 0.0, 0.0], "order": 1}


def layout() -> Split:
    """The view: the 3-D scene left; camera, state over time and status right."""
    camera = Panel("Image", "camera", "overhead camera", {
        "imageMode": {"imageTopic": CAMERA_TOPIC, "calibrationTopic": CAMERA_INFO_TOPIC}})
    states = Panel("StateTransitions", "state", "executor state", {
        "paths": [{"value": f"{STATUS_TOPIC}.state", "label": "state",
                   "timestampMethod": "receiveTime", "enabled": True}],
        "isSynced": True})
    status = Panel("RawMessages", "status", "executor status", {
        "topicPath": STATUS_TOPIC, "diffEnabled": False, "diffMethod": "custom",
        "diffTopicPath": "", "showFullMessageForDiff": False, "expansion": "all"})
    right = Split("column", camera, Split("column", states, status, 30.0), 55.0)
    return Split("row", scene_panel(), right, 60.0)


def layout_json() -> str:
    """The layout file's text: indented JSON, keys in a fixed order."""
    return json.dumps(layout_data(layout()), indent=2) + "\n"


def write_layout(path: Path | None = None) -> Path:
    """Write the layout file (default: the repository's); returns where."""
    target = path or config_path(LAYOUT_FILE)
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(layout_json())
    return target
