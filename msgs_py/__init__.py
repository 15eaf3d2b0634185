"""densepack's typed message layer: dataclasses, versioned documents and ROS codecs.

Everything here except the ``msgs_py.ros`` package (its codecs to and from ROS messages; not
imported here) is free of ROS imports, so planners and tests can use it without a ROS
installation.
"""

from msgs_py.actions import Action, PickPlace, Plan, Push, action_from_dict
from msgs_py.detection import BlockSet
from msgs_py.documents import load_plan, load_scene, parse_text, save_plan, save_scene
from msgs_py.errors import MessageError
from msgs_py.goal import Goal, GoalSlot, GridSpec
from msgs_py.poses import BlockPose, Pose2D, wrap_angle, yaw_difference
from msgs_py.scene import SCHEMA_VERSION, Scene, Workspace
from msgs_py.status import EXECUTOR_STATES, PLANNER_STATES, ExecutorStatus, PlannerStatus

__all__ = [
    "EXECUTOR_STATES",
    "PLANNER_STATES",
    "SCHEMA_VERSION",
    "Action",
    "BlockPose",
    "BlockSet",
    "ExecutorStatus",
    "Goal",
    "GoalSlot",
    "GridSpec",
    "MessageError",
    "PickPlace",
    "Plan",
    "PlannerStatus",
    "Pose2D",
    "Push",
    "Scene",
    "Workspace",
    "action_from_dict",
    "load_plan",
    "load_scene",
    "parse_text",
    "save_plan",
    "save_scene",
    "wrap_angle",
    "yaw_difference",
]
