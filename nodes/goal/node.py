"""``densepack-goal``: publishes a scene file's goal layout, latched, on ``/goal_layout``.

The user's side of the goal (user -> planner), the latched-topic style: the layout is the
scene file without its blocks (workspace, block size, goal, labeled), validated by msgs_py
before it is sent, so a bad file is refused here with a message naming the field, not
downstream. The action style is ``/rearrange`` (``densepack-run`` is its client).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

from densepack_interfaces.msg import GoalLayout
from rclpy.node import Node

from msgs_py import MessageError, Scene, load_scene
from msgs_py.ros import goal_layout_to_msg
from nodes.common.params import declare_config, param
from nodes.common.paths import config_path
from nodes.common.qos import LATCHED
from nodes.common.runner import NodeSpec, run_node


@dataclass(frozen=True)
class GoalConfig:
    scene_file: str = param("scenes/default.yaml", "scene file whose goal is published")


def goal_layout(scene: Scene) -> Scene:
    """The part of a scene the planner needs from the user: everything but the blocks."""
    if scene.goal is None:
        raise MessageError("goal", None, "the scene file has no goal")
    return Scene(scene.workspace, scene.block_size, (), scene.goal, scene.version)


class GoalPublisher(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("goal", **kwargs)
        self.config = declare_config(self, GoalConfig)
        self.publisher = self.create_publisher(GoalLayout, "/goal_layout", LATCHED)
        path = config_path(self.config.scene_file)
        layout = goal_layout(load_scene(path))
        self.publisher.publish(goal_layout_to_msg(layout, self.get_clock().now().nanoseconds))
        self.get_logger().info(
            f"published the goal of {path} on /goal_layout ({layout.goal.n_slots} slots, "
            f"labeled={layout.goal.labeled})"
        )


SPEC = NodeSpec(
    "goal",
    GoalPublisher,
    "Publishes the goal layout of a scene file, latched, on /goal_layout "
    "(densepack_interfaces/GoalLayout).",
    configs=(("", GoalConfig),),
)


def main(args=None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
