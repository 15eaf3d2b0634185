"""The executor's inputs: one narrow surface through which everything it senses enters.

``ExecutorInputs`` is every input the core takes, each in the core's own terms (ROS time in
seconds or nanoseconds, metres, ``msgs_py`` records), whoever produces it: the executor node
decodes them from the arm node's, the gripper node's, the camera's and the detector's
topics. Between ticks the node calls these; ``tick(now)`` then acts on them. ``Inbox`` keeps
what the arm and the gripper last reported for the tick to read.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

from msgs_py import BlockSet, Plan
from msgs_py.status import ArmStatus, GripperStatus
from nodes.executor.motion import ToolPose


class ExecutorInputs(Protocol):
    """What the executor core is told, and by whom (in the cell as it is now)."""

    def on_tcp(self, pose: ToolPose, stamp_s: float | None = None) -> None:
        """The arm: the measured TCP, taken at ``stamp_s`` (ROS time, s; None: now)."""

    def on_arm_joints(self, q: Sequence[float], stamp_s: float | None = None) -> None:
        """The arm driver's joint states (kinematic order, rad) at ``stamp_s``: which of the
        IK's branches the arm is on, and what it covers in the camera's view now and a
        frame's delay on (for predicting and for triggering a look on the way)."""

    def on_finger_gap(self, gap: float, stamp_s: float | None = None) -> None:
        """The gripper's finger joints: the gap between the pads (m) at ``stamp_s``."""

    def on_gripper(self, reading: GripperStatus) -> None:
        """The gripper driver's status: gap, request and object detection."""

    def on_gripper_command_resent(self) -> None:
        """The executor's own lease client: the fingers' last command went again, to a
        gripper node that restarted (its reports echo it only once it arrives)."""

    def on_arm_status(self, status: ArmStatus) -> None:
        """The arm node: the arm can move, or it is held (a protective stop, a stopped
        program, lost joint states, the slider at 0) and why."""

    def on_arm_lost(self, why: str | None) -> None:
        """The executor node's ``ArmWatch``: the arm node is gone, or back but not yet taking
        the executor's setpoints (why), or taking them (None)."""

    def on_frame_taken(self, stamp_ns: int) -> None:
        """The camera: the frame the executor asked for was taken at ``stamp_ns``."""

    def on_detection(self, detection: BlockSet) -> None:
        """The detector: block poses seen in a frame (only one taken after the executor's
        own request counts as an observation)."""

    def on_plan(self, plan: Plan) -> None:
        """The planner: a plan (latched; the same one again is ignored)."""

    def on_planner_waiting(self, for_detection: bool, why: str = "") -> None:
        """The planner: whether it waits for a detection to plan from, and why."""

    def on_planner_failed(self, reason: str) -> None:
        """The planner: no plan for the executor's replan request."""

    def request_start(self) -> str:
        """An operator or a goal: start (or resume) a run; the answer in words."""

    def request_stop(self) -> str:
        """An operator or a goal's cancel: stop safely; the answer in words."""


@dataclass
class Inbox:
    """What the arm and the gripper reported: the latest TCP and finger gap, and the gap
    samples and gripper readings since the last tick that used them."""

    tcp: ToolPose | None = None
    tcp_stamp: float | None = None  #: ROS time (s) the TCP was measured at (None: now)
    arm_joints: tuple[float, ...] | None = None  #: the latest (kinematic order, rad)
    arm_joints_stamp: float | None = None  #: ROS time (s) of ``arm_joints``
    #: the joints' rates (rad/s) between the last two joint states (None: not known)
    arm_rates: tuple[float, ...] | None = None
    finger_gap: float | None = None
    gaps: list[tuple[float, float]] = field(default_factory=list)  #: (time s, gap m)
    readings: list[GripperStatus] = field(default_factory=list)
    #: the gripper has sent finger measurements: one silent after a command is not there
    gripper_reports: bool = False

    def on_tcp(self, pose: ToolPose, stamp_s: float | None) -> None:
        self.tcp, self.tcp_stamp = pose, stamp_s

    def on_arm_joints(self, q: Sequence[float], stamp_s: float | None) -> None:
        q = tuple(float(v) for v in q)
        before, then = self.arm_joints, self.arm_joints_stamp
        self.arm_rates = None
        if (stamp_s is not None and then is not None and stamp_s > then and before is not None
                and len(before) == len(q)):
            self.arm_rates = tuple((a - b) / (stamp_s - then) for a, b in zip(q, before,
                                                                               strict=True))
        self.arm_joints, self.arm_joints_stamp = q, stamp_s

    def on_finger_gap(self, gap: float, stamp_s: float | None) -> None:
        self.finger_gap = gap
        if stamp_s is not None:
            self.gaps.append((stamp_s, gap))
            self.gripper_reports = True

    def on_gripper(self, reading: GripperStatus) -> None:
        self.finger_gap = reading.gap
        self.gaps.append((reading.stamp_ns * 1e-9, reading.gap))
        self.readings.append(reading)
        self.gripper_reports = True

    def take_gaps(self) -> list[tuple[float, float]]:
        gaps, self.gaps = self.gaps, []
        return gaps

    def take_readings(self) -> list[GripperStatus]:
        readings, self.readings = self.readings, []
        return readings
