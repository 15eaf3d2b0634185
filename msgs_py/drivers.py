"""What the real cell's drivers speak, as plain values: ur_robot_driver's safety and robot
modes (the constants of ur_dashboard_msgs/SafetyMode and RobotMode), its topics and services,
and the Robotiq 2F-85 driver's, as their launch files name them.

The arm and gripper nodes talk to these names; the sim serves them as the drivers do. Both use
this one table, so codes and names cannot drift apart (a real cell renames with remappings:
``config/real/``). No ROS import.
"""

from __future__ import annotations

#: ur_dashboard_msgs/SafetyMode ``mode`` codes (uint8).
SAFETY_MODE_NAMES = {
    1: "normal",
    2: "reduced",
    3: "protective_stop",
    4: "recovery",
    5: "safeguard_stop",
    6: "system_emergency_stop",
    7: "robot_emergency_stop",
    8: "violation",
    9: "fault",
    10: "validate_joint_id",
    11: "undefined_safety_mode",
    12: "automatic_mode_safeguard_stop",
    13: "system_three_position_enabling_stop",
}
SAFETY_NORMAL = 1
SAFETY_REDUCED = 2
SAFETY_PROTECTIVE_STOP = 3
#: Safety modes in which the robot moves (a reduced mode moves slower, but moves).
SAFETY_MOVING = (SAFETY_NORMAL, SAFETY_REDUCED)

#: ur_dashboard_msgs/RobotMode ``mode`` codes (int8).
ROBOT_MODE_NAMES = {
    -1: "no_controller",
    0: "disconnected",
    1: "confirm_safety",
    2: "booting",
    3: "power_off",
    4: "power_on",
    5: "idle",
    6: "backdrive",
    7: "running",
    8: "updating_firmware",
}
ROBOT_POWER_OFF = 3
ROBOT_IDLE = 5
ROBOT_RUNNING = 7

# --- names (ur_robot_driver's launch with its default controllers, no tf_prefix) -------------
JOINT_STATES = "/joint_states"
TRAJECTORY_TOPIC = "/scaled_joint_trajectory_controller/joint_trajectory"
FORWARD_POSITION_TOPIC = "/forward_position_controller/commands"
TCP_POSE_TOPIC = "/tcp_pose_broadcaster/pose"
#: std_msgs/Float64, in percent (the broadcaster multiplies the fraction by 100).
SPEED_SCALING_TOPIC = "/speed_scaling_state_broadcaster/speed_scaling"
SAFETY_MODE_TOPIC = "/io_and_status_controller/safety_mode"
ROBOT_MODE_TOPIC = "/io_and_status_controller/robot_mode"
PROGRAM_RUNNING_TOPIC = "/io_and_status_controller/robot_program_running"
#: The dashboard client's std_srvs/Trigger services.
DASHBOARD = "/dashboard_client"
DASHBOARD_TRIGGERS = ("unlock_protective_stop", "close_safety_popup", "stop", "play", "pause",
                      "power_on", "power_off", "brake_release")
#: The frame ur_robot_driver reports the TCP pose in (the controller's base).
BASE_FRAME = "base"


def dashboard_service(name: str) -> str:
    """The dashboard client's service ``name`` (e.g. ``unlock_protective_stop``)."""
    if name not in DASHBOARD_TRIGGERS:
        raise ValueError(f"no dashboard service '{name}'; known: {list(DASHBOARD_TRIGGERS)}")
    return f"{DASHBOARD}/{name}"


def safety_mode_name(code: int) -> str:
    return SAFETY_MODE_NAMES.get(int(code), f"unknown safety mode {code}")


def robot_mode_name(code: int) -> str:
    return ROBOT_MODE_NAMES.get(int(code), f"unknown robot mode {code}")


# --- the Robotiq 2F-85 driver, launched in its own namespace (its controller manager) --------
GRIPPER_NAMESPACE = "/gripper"
#: Its joint_state_broadcaster: the knuckle joint only (``nodes.robot.gripper_2f85``).
GRIPPER_JOINT_STATES = f"{GRIPPER_NAMESPACE}/joint_states"
#: A forward position controller on the knuckle joint (std_msgs/Float64MultiArray, rad), as the
#: driver's controllers file can configure one (``config/real/robotiq_controllers.yaml``).
GRIPPER_POSITION_CONTROLLER = "robotiq_position_controller"
GRIPPER_COMMAND_TOPIC = f"{GRIPPER_NAMESPACE}/{GRIPPER_POSITION_CONTROLLER}/commands"
GRIPPER_REACTIVATE = f"{GRIPPER_NAMESPACE}/robotiq_activation_controller/reactivate_gripper"
