"""Executor parameters (config/executor.yaml), declared on the node from this dataclass."""

from __future__ import annotations

import math
from dataclasses import dataclass

from msgs_py import cell
from nodes.common.params import param
from nodes.executor.motion import Limits, ToolPose


@dataclass(frozen=True)
class ExecutorConfig:
    rate_hz: float = param(50.0, "setpoint streaming rate (on ROS time); the arm controller "
                           "interpolates between setpoints", unit="Hz")
    auto_start: bool = param(True, "start executing as soon as a plan arrives")
    travel_height: float = param(
        cell.TRAVEL_HEIGHT,
        "TCP height for moves above the blocks: a carried block's bottom clears 5 cm "
        "blocks by 3.7 cm", unit="m")
    grasp_height: float = param(
        cell.GRASP_HEIGHT,
        "TCP (fingertip) height when closing on a block: pads grip its lower part",
        unit="m")
    place_drop: float = param(
        cell.PLACE_DROP, "release a placed block this far above its resting height", unit="m")
    push_height: float = param(
        cell.PUSH_HEIGHT,
        "fingertip height during a push: low on the face so the block does not tip",
        unit="m")
    push_backoff: float = param(
        0.006, "after a push, back off this far along -d before lifting", unit="m")
    speed: float = param(1.0, "max TCP speed for travel (UR10e: 1 m/s)", unit="m/s")
    accel: float = param(4.0, "peak TCP acceleration for travel (cosine ramps: the mean over "
                         "a ramp is 2/pi of it)", unit="m/s^2")
    descend_speed: float = param(
        0.5, "max TCP speed descending or lifting above the last approach_distance",
        unit="m/s")
    approach_distance: float = param(
        0.015, "the last stretch of a descent onto a block, a table spot or behind a block, "
        "taken at approach_speed", unit="m")
    approach_speed: float = param(
        0.1, "TCP speed over the last approach_distance: contact happens slowly", unit="m/s")
    push_speed: float = param(0.1, "TCP speed along a push (quasi-static sliding)",
                              unit="m/s")
    push_accel: float = param(
        0.5, "TCP acceleration along a push: far below friction's deceleration (~3.4 m/s^2), "
        "so the block never slides ahead of the fingers", unit="m/s^2")
    yaw_rate: float = param(3.0, "max tool yaw rate (UR10e wrist 3: 180 deg/s)", unit="rad/s")
    yaw_accel: float = param(12.0, "peak tool yaw acceleration", unit="rad/s^2")
    blend_radius: float = param(
        0.025, "lift -> carry and retreat -> travel corners are rounded within this radius "
        "(a carried block still clears the others by 1.2 cm)", unit="m")
    pick_clearance: float = param(
        0.016, "finger clearance on each side when going down around a block to pick it, where "
        "no neighbour is in the way (else the plan's approach_clearance): room for a camera "
        "that is off by a centimetre until perception and arm are brought to agree", unit="m")
    release_clearance: float = param(
        0.004, "finger clearance on each side as the fingers open to let a placed block go (the "
        "block is where they hold it: a few mm lift off cleanly, and the finger towards a "
        "neighbour stays approach_clearance - this further from it than the plan checked); "
        "also the narrower opening a pick goes down with where the plan's would bring a "
        "finger within a millimetre of a neighbour", unit="m")
    gripper_settle_s: float = param(
        0.3, "wait after a gripper command when the gripper reports no finger positions "
        "(with them, the executor waits until the fingers reach the opening or stop)",
        unit="s")
    grip_command: float = param(
        0.0, "opening commanded to grip: the force-limited fingers stop on the block", unit="m")
    convergence_tol: float = param(
        0.002, "measured TCP must come this close to a move's end point", unit="m")
    convergence_timeout_s: float = param(
        10.0, "give up when the TCP, measured this long after a move's end, is still not "
        "there (generous: a setpoint can reach the arm late on a loaded machine)", unit="s")
    safe_box: tuple = param(
        [-0.3, 1.4, -0.95, 0.95, 0.004, 0.9],
        "box every setpoint must stay in: x_min, x_max, y_min, y_max, z_min, z_max", unit="m")
    park_pose: tuple = param(
        [0.25, -0.55, 0.40, 0.0], "TCP pose out of the camera's view: x, y, z, yaw",
        unit="m, rad")
    look_offset: float = param(
        0.10, "after an action the arm looks from this far outside the workspace's robot-side "
        "edge (x_min), where no part of it hides a block from the overhead camera", unit="m")
    look_height: float = param(0.25, "TCP height of the look pose", unit="m")
    look_while_moving: bool = param(
        True, "judge each action from a frame taken while the arm already travels to the next "
        "block, at the moment its predicted silhouette leaves in view the blocks the next "
        "action needs judged; the look pose only when no moment on the way does, or the frame "
        "shows one covered after all. At the look pose, move on once the frame is taken. The "
        "action starts once the frame is judged")
    judge_radius: float = param(
        0.08, "blocks standing this close to an action's pick, place or push path (centres) "
        "are judged before it goes down (anything may have moved them since the last frame); "
        "those near an action done, as soon as a frame shows them", unit="m")
    calibration_file: str = param(
        "camera_calibration.yaml", "the camera's pose (the detector's calibration file; "
        "relative: under config/), to predict when the arm leaves blocks in view; unreadable: "
        "every action is judged from the look pose")
    pos_tolerance: float = param(
        cell.PLACED_TOLERANCE_XY,
        "a block further than this from its expected pose needs a correction",
        unit="m")
    yaw_tolerance_deg: float = param(
        cell.PLACED_TOLERANCE_YAW_DEG, "yaw tolerance (modulo 90 degrees)", unit="deg")
    accept_pos_tolerance: float = param(
        cell.ACCEPT_TOLERANCE_XY,
        "when the planner finds no correction, blocks this close to their goal end the "
        "run as done (the residual is reported)", unit="m")
    accept_yaw_tolerance_deg: float = param(
        cell.ACCEPT_TOLERANCE_YAW_DEG,
        "... and this close in yaw (modulo 90 degrees)", unit="deg")
    camera_check: bool = param(
        True, "before the first action of the executor's first run, grip the most isolated "
        "block in place along both its axes so the detector can check its calibration "
        "against the arm (nodes/executor/camera_check.py)")
    camera_check_margin: float = param(
        0.015, "the camera check's block: its widest-open fingers clear every neighbour by "
        "this much, for a camera up to this far off", unit="m")
    observe_every_action: bool = param(
        True, "take a fresh detection after every action (closed loop): on the way to the "
        "next block, or from the look pose")
    detection_timeout_s: float = param(
        6.0, "wait this long for a detection after a camera trigger", unit="s")
    detection_retries: int = param(5, "camera triggers before giving up on a detection")
    idle_look_period_s: float = param(
        5.0, "without a plan: park and trigger the camera this often, so the planner sees the "
        "blocks with the arm out of view (0 = never)", unit="s")
    max_replans: int = param(6, "replans (drift corrections) before the executor gives up")
    replan_timeout_s: float = param(60.0, "wait this long for a new plan", unit="s")
    take_control: bool = param(
        True, "hold the arm's and the gripper's leases (/arm/lease, /gripper/lease) while a run "
        "goes (observing, running, recovering, replanning, stopping): the arm and gripper nodes "
        "then refuse and name any other commander; without them (or this off) the executor "
        "commands on the public topics")

    def __post_init__(self) -> None:
        if self.rate_hz <= 0:
            raise ValueError(f"parameter 'rate_hz' must be > 0, got {self.rate_hz}")
        if len(self.safe_box) != 6:
            raise ValueError(f"parameter 'safe_box' needs 6 numbers, got {list(self.safe_box)}")
        if len(self.park_pose) != 4:
            raise ValueError(f"parameter 'park_pose' needs x, y, z, yaw, got {self.park_pose}")
        if not self.grasp_height + self.approach_distance < self.travel_height:
            raise ValueError("parameters 'grasp_height' + 'approach_distance' must be below "
                             "'travel_height'")
        for name in ("speed", "accel", "descend_speed", "approach_speed", "push_speed",
                     "push_accel", "yaw_rate", "yaw_accel", "release_clearance"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"parameter '{name}' must be > 0, got {getattr(self, name)}")
        if not self.in_safe_box(self.park):
            raise ValueError(f"parameter 'park_pose' {self.park_pose} is outside 'safe_box'")

    @property
    def park(self) -> ToolPose:
        return ToolPose(*self.park_pose)

    @property
    def yaw_tolerance(self) -> float:
        return math.radians(self.yaw_tolerance_deg)

    @property
    def accept_yaw_tolerance(self) -> float:
        return math.radians(self.accept_yaw_tolerance_deg)

    @property
    def travel_limits(self) -> Limits:
        return Limits(self.speed, self.accel, self.yaw_rate, self.yaw_accel)

    @property
    def vertical_limits(self) -> Limits:
        return Limits(self.descend_speed, self.accel, self.yaw_rate, self.yaw_accel)

    @property
    def approach_limits(self) -> Limits:
        return Limits(self.approach_speed, self.accel, self.yaw_rate, self.yaw_accel)

    @property
    def push_limits(self) -> Limits:
        return Limits(self.push_speed, self.push_accel, self.yaw_rate, self.yaw_accel)

    def in_safe_box(self, pose: ToolPose) -> bool:
        x0, x1, y0, y1, z0, z1 = self.safe_box
        return x0 <= pose.x <= x1 and y0 <= pose.y <= y1 and z0 <= pose.z <= z1
