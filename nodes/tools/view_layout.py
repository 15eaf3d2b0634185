"""The Foxglove layout of ``densepack-view`` (``config/foxglove/densepack-layout.json``), built
with ``foxglove.layouts`` so the file is the SDK's own format, not JSON written by hand.

Left, the 3-D scene in ``world`` (``/view/scene``: detected blocks, goal slots, the plan's
arrows, the TCP; the detector's and the plan's MarkerArrays off by default, one toggle away);
right, the overhead camera (``/camera/image_raw/compressed``) above the executor's state over
time and its latest ``/executor/status`` message, decoded with its ``ros2msg`` schema.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from nodes.common.paths import config_path

#: The repository's layout file (config/).
LAYOUT_FILE = "foxglove/densepack-layout.json"
SCENE_TOPIC = "/view/scene"
CAMERA_TOPIC = "/camera/image_raw/compressed"
STATUS_TOPIC = "/executor/status"


def layout() -> Any:
    """The layout as a ``foxglove.layouts.Layout``."""
    import foxglove.layouts as fl

    scene = fl.ThreeDeePanel(title="cell (world)", config=fl.ThreeDeeConfig(
        follow_tf="world",
        camera_state=fl.ThreeDeeCameraState(distance=1.6, phi=50.0, theta_offset=-90.0,
                                            target=(0.6, 0.0, 0.0), perspective=True),
        topics={
            SCENE_TOPIC: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
            "/tcp_pose": fl.BaseRendererPoseTopicSettings(visible=True, type="axis",
                                                          axis_scale=0.5),
            "/blocks/detected/markers": fl.BaseRendererRosMarkerTopicSettings(visible=False),
            "/plan/markers": fl.BaseRendererRosMarkerTopicSettings(visible=False),
        }))
    camera = fl.ImagePanel(title="overhead camera", config=fl.ImageConfig(
        image_mode=fl.ImageModeConfig(image_topic=CAMERA_TOPIC,
                                      calibration_topic="/camera/camera_info")))
    states = fl.StateTransitionsPanel(title="executor state", config=fl.StateTransitionsConfig(
        paths=[fl.StateTransitionsSeries(value=f"{STATUS_TOPIC}.state", label="state")]))
    status = fl.RawMessagesPanel(title="executor status", config=fl.RawMessagesConfig(
        topic_path=STATUS_TOPIC, expansion="all"))
    right = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=3, content=camera),
        fl.SplitItem(proportion=1, content=states),
        fl.SplitItem(proportion=2, content=status)])
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=3, content=scene), fl.SplitItem(proportion=2, content=right)]))


def layout_json() -> str:
    """The layout file's text: the SDK's JSON, indented, keys in the SDK's order."""
    return json.dumps(json.loads(layout().to_json()), indent=2) + "\n"


def write_layout(path: Path | None = None) -> Path:
    """Write the layout file (default: the repository's); returns where."""
    target = path or config_path(LAYOUT_FILE)
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(layout_json())
    return target
