"""Can the arm follow setpoints now, and if not, why: the driver's state turned into what the
executor needs.

Pure logic (no ROS). ur_robot_driver reports a safety mode, a robot mode and whether its
External Control program runs, each latched, and the speed slider; the arm node measures the
joints itself. ``judge`` reduces them to one ``ArmState`` and a reason in words, in this order
(the first that applies):

1. ``no_joint_states``: none yet, one that lacks an arm joint, or none for
   ``joint_state_timeout_s``: the node cannot know where the arm is, so it does not move it.
2. ``protective_stop``: the safety system stopped the arm; the executor asks the arm node to
   unlock it (``nodes.arm.unlock``: unlock, restart the program, wait until it runs).
3. ``stopped``: the arm cannot move until someone acts: a safeguard or emergency stop (any
   safety mode other than normal and reduced), the robot not running (powered off, brakes on),
   the program not running, or the driver's state not yet known.
4. ``paused``: the speed slider is at 0: setpoints are taken, the arm stands on its path.
5. ``ready``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from msgs_py.drivers import (
    ROBOT_RUNNING,
    SAFETY_MOVING,
    SAFETY_PROTECTIVE_STOP,
    robot_mode_name,
    safety_mode_name,
)
from msgs_py.status import ARM_STATES


@dataclass(frozen=True, slots=True)
class DriverState:
    """The latest of what the driver reported (None: nothing yet)."""

    safety_mode: int | None = None
    robot_mode: int | None = None
    program_running: bool | None = None
    speed_scaling: float | None = None  #: fraction (the driver publishes percent)


@dataclass(frozen=True, slots=True)
class ArmState:
    state: str
    reason: str = ""

    def __post_init__(self) -> None:
        if self.state not in ARM_STATES:
            raise ValueError(f"arm state '{self.state}' is not one of {list(ARM_STATES)}")

    @property
    def moves(self) -> bool:
        """Setpoints are followed (possibly at a reduced speed)."""
        return self.state == "ready"


def judge(driver: DriverState, joints_age_s: float | None, missing_joints: tuple[str, ...],
          joint_state_timeout_s: float, unlocking: bool = False) -> ArmState:
    """The arm's state from the driver's report and the age (s) of the newest complete joint
    state (None: none yet)."""
    if missing_joints:
        return ArmState("no_joint_states",
                        f"/joint_states lacks {', '.join(missing_joints)}")
    if joints_age_s is None:
        return ArmState("no_joint_states", "no /joint_states received yet")
    if joints_age_s > joint_state_timeout_s:
        return ArmState("no_joint_states",
                        f"no /joint_states for {joints_age_s:.1f} s "
                        f"(timeout {joint_state_timeout_s:.1f} s)")
    if driver.safety_mode == SAFETY_PROTECTIVE_STOP or unlocking:
        return ArmState("protective_stop", "the robot is in a protective stop" if not unlocking
                        else "unlocking the protective stop and restarting the program")
    if driver.safety_mode is None or driver.robot_mode is None or driver.program_running is None:
        return ArmState("stopped", "waiting for the driver's safety mode, robot mode and "
                                   "program state")
    if driver.safety_mode not in SAFETY_MOVING:
        return ArmState("stopped", f"safety mode {safety_mode_name(driver.safety_mode)}")
    if driver.robot_mode != ROBOT_RUNNING:
        return ArmState("stopped", f"robot mode {robot_mode_name(driver.robot_mode)} "
                                   "(power on and release the brakes)")
    if not driver.program_running:
        return ArmState("stopped", "the robot program is not running (press play on the "
                                   "pendant, or call /dashboard_client/play)")
    if driver.speed_scaling is not None and driver.speed_scaling <= 0.0:
        return ArmState("paused", "the speed slider is at 0 %: the arm waits on its path")
    return ArmState("ready")


def percent_to_fraction(percent: float) -> float:
    """The driver's speed scaling (percent) as a fraction in [0, 1]; refuses non-finite."""
    if not math.isfinite(percent):
        raise ValueError(f"speed scaling {percent} % is not finite")
    return min(max(percent / 100.0, 0.0), 1.0)
