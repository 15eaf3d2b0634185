"""The arm node's parameters (frozen dataclass; names, defaults, units as in config/arm.yaml)."""

from __future__ import annotations

from dataclasses import dataclass

from nodes.common.lease import LeaseConfig
from nodes.common.params import param

COMMAND_INTERFACES = ("trajectory", "forward_position")


@dataclass(frozen=True)
class ArmConfig:
    command_interface: str = param(
        "trajectory", "how joint commands go to ur_robot_driver: 'trajectory' (short "
        "JointTrajectory snippets to scaled_joint_trajectory_controller, the default) or "
        "'forward_position' (Float64MultiArray to forward_position_controller); the driver "
        "must run the matching controller (its launch argument initial_joint_controller)")
    command_rate_hz: float = param(
        50.0, "how often a command goes to the driver (on the node's clock: sim time in the "
        "sim cell)", unit="Hz")
    horizon_s: float = param(
        0.08, "each trajectory snippet covers this much of the commanded motion ahead of now; "
        "at most servo_delay_s (the playback cannot run further ahead of the setpoints)",
        unit="s")
    point_spacing_s: float = param(0.02, "time between a snippet's points", unit="s")
    servo_delay_s: float = param(
        0.08, "streamed setpoints are played back this far behind their stamps, interpolated "
        "(like a UR servoj lookahead), so late setpoints still join a smooth path", unit="s")
    control_rate_hz: float = param(
        240.0, "the controller's own step rate: joint velocity and acceleration limits are "
        "kept per step of 1/control_rate_hz", unit="Hz")
    min_tcp_z: float = param(0.0, "safety plane: setpoints with the TCP below it are refused",
                             unit="m")
    speed_scale: float = param(1.0, "fraction (0-1] of the UR10e joint velocity limits used")
    joint_state_timeout_s: float = param(
        0.5, "joint states older than this (by their stamps, on the node's clock) mean the "
        "arm's position is unknown: the node stops commanding and says so", unit="s")
    program_timeout_s: float = param(
        5.0, "after unlocking a protective stop and playing the program, wait this long for "
        "the driver to report the program running", unit="s")
    dashboard_timeout_s: float = param(
        10.0, "a dashboard call not answered within this long fails the unlock", unit="s")
    status_rate_hz: float = param(10.0, "/arm/status rate when nothing changes", unit="Hz")

    def __post_init__(self) -> None:
        if self.command_interface not in COMMAND_INTERFACES:
            raise ValueError(f"command_interface must be one of {list(COMMAND_INTERFACES)}, "
                             f"got '{self.command_interface}'")
        for name in ("command_rate_hz", "control_rate_hz", "status_rate_hz", "point_spacing_s",
                     "horizon_s", "joint_state_timeout_s", "program_timeout_s",
                     "dashboard_timeout_s"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not self.point_spacing_s <= self.horizon_s <= self.servo_delay_s:
            raise ValueError(f"need point_spacing_s ({self.point_spacing_s}) <= horizon_s "
                             f"({self.horizon_s}) <= servo_delay_s ({self.servo_delay_s})")
        if not 1.0 / self.control_rate_hz <= self.point_spacing_s:
            raise ValueError("point_spacing_s must be at least one control step")
        if not 0.0 < self.speed_scale <= 1.0:
            raise ValueError(f"speed_scale must be in (0, 1], got {self.speed_scale}")


ARM_PARAMETERS = (("", ArmConfig), ("lease.", LeaseConfig))
