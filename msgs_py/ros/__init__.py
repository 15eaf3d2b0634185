"""The ROS side of the message layer: codecs between msgs_py's records and ROS messages.

``import msgs_py`` stays free of ROS; this package is imported only where ROS messages are
wanted (node adapters, tools, tests that publish). Its modules, one concept each:

* ``stamps``: ``builtin_interfaces/Time`` <-> integer nanoseconds.
* ``markers``: a ``BlockSet`` as a ``visualization_msgs/MarkerArray`` for viewers.
* ``scene``, ``plan``, ``status``, ``sim``, ``rearrange``: the ``densepack_interfaces`` types
  (built from ``ros_ws/src/densepack_interfaces`` by pip or colcon), with ``fields`` holding
  the checks they share and ``dispatch`` the one table by type (``to_msg``, ``from_msg``).
* ``image``: ``sensor_msgs`` images and camera info <-> numpy and ``CameraIntrinsics``; it needs
  OpenCV, so it is imported on its own (``from msgs_py.ros.image import ...``), not here.

For every record, ``X_to_msg`` builds the typed message and ``X_from_msg`` decodes one,
validating as it goes: a NaN, an unknown state or action type, a duplicate id, an id out of
range, a field filled that the message's own discriminator says is unused... raises
``MessageError`` naming the offending field by its message path (``blocks[2].pose.x``,
``goal.slots[0].block_id``, ``actions[4].type``). dataclass -> message -> dataclass gives back
an equal dataclass. Conventions:

* Poses are ``PlanarPose`` (x, y, theta in float64), so yaws travel bit-exact.
* Optional block ids travel as the message's ``NO_BLOCK`` / ``ANY_BLOCK`` (-1).
* Vocabularies (states, outcomes, errors, action types) travel as the messages' constants.
* Dicts of figures travel as ``Metric[]``; plan parameters and planner overrides as
  ``rcl_interfaces/Parameter[]`` (typed; a list must hold one type; lists decode as lists).
* Scenes and goal layouts are in ``world``; their header's ``frame_id`` is written ``world``
  and an empty one is read as ``world``.
* Stamps that the dataclasses do not hold (status, scene headers) are taken as an argument.
"""

from msgs_py.ros.dispatch import (
    from_msg,
    to_msg,
)
from msgs_py.ros.markers import (
    block_set_to_markers,
    yaw_to_quaternion_xyzw,
)
from msgs_py.ros.plan import (
    action_from_msg,
    action_to_msg,
    params_from_msg,
    params_to_msg,
    plan_from_msg,
    plan_reply_from_msg,
    plan_reply_to_msg,
    plan_request_from_msg,
    plan_request_to_msg,
    plan_to_msg,
)
from msgs_py.ros.rearrange import (
    block_error_from_msg,
    block_error_to_msg,
    rearrange_feedback_from_msg,
    rearrange_feedback_to_msg,
    rearrange_goal_from_msg,
    rearrange_goal_to_msg,
    rearrange_result_from_msg,
    rearrange_result_to_msg,
)
from msgs_py.ros.scene import (
    block_pose_from_msg,
    block_pose_to_msg,
    block_set_from_msg,
    block_set_to_msg,
    goal_from_msg,
    goal_layout_from_msg,
    goal_layout_to_msg,
    goal_to_msg,
    grid_from_msg,
    grid_to_msg,
    pose_from_msg,
    pose_to_msg,
    scene_from_msg,
    scene_to_msg,
    workspace_from_msg,
    workspace_to_msg,
)
from msgs_py.ros.sim import (
    disturbance_from_msg,
    disturbance_to_msg,
    placement_from_msg,
    placement_to_msg,
    sim_event_from_msg,
    sim_event_to_msg,
    sim_events_from_msg,
    sim_events_to_msg,
    sim_fault_from_msg,
    sim_fault_to_msg,
)
from msgs_py.ros.stamps import (
    ns_to_stamp,
    stamp_to_ns,
)
from msgs_py.ros.status import (
    arm_status_from_msg,
    arm_status_to_msg,
    executor_status_from_msg,
    executor_status_to_msg,
    gripper_status_from_msg,
    gripper_status_to_msg,
    metrics_from_msg,
    metrics_to_msg,
    planner_status_from_msg,
    planner_status_to_msg,
)

__all__ = [
    "action_from_msg",
    "action_to_msg",
    "arm_status_from_msg",
    "arm_status_to_msg",
    "block_error_from_msg",
    "block_error_to_msg",
    "block_pose_from_msg",
    "block_pose_to_msg",
    "block_set_from_msg",
    "block_set_to_markers",
    "block_set_to_msg",
    "disturbance_from_msg",
    "disturbance_to_msg",
    "executor_status_from_msg",
    "executor_status_to_msg",
    "from_msg",
    "goal_from_msg",
    "goal_layout_from_msg",
    "goal_layout_to_msg",
    "goal_to_msg",
    "grid_from_msg",
    "grid_to_msg",
    "gripper_status_from_msg",
    "gripper_status_to_msg",
    "metrics_from_msg",
    "metrics_to_msg",
    "ns_to_stamp",
    "params_from_msg",
    "params_to_msg",
    "placement_from_msg",
    "placement_to_msg",
    "plan_from_msg",
    "plan_reply_from_msg",
    "plan_reply_to_msg",
    "plan_request_from_msg",
    "plan_request_to_msg",
    "plan_to_msg",
    "planner_status_from_msg",
    "planner_status_to_msg",
    "pose_from_msg",
    "pose_to_msg",
    "rearrange_feedback_from_msg",
    "rearrange_feedback_to_msg",
    "rearrange_goal_from_msg",
    "rearrange_goal_to_msg",
    "rearrange_result_from_msg",
    "rearrange_result_to_msg",
    "scene_from_msg",
    "scene_to_msg",
    "sim_event_from_msg",
    "sim_event_to_msg",
    "sim_events_from_msg",
    "sim_events_to_msg",
    "sim_fault_from_msg",
    "sim_fault_to_msg",
    "stamp_to_ns",
    "to_msg",
    "workspace_from_msg",
    "workspace_to_msg",
    "yaw_to_quaternion_xyzw",
]
