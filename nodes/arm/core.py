"""The arm node's logic, free of ROS: Cartesian setpoints and the driver's reports in, joint
commands, dashboard calls and the arm's status out.

``ArmCore`` is what ``densepack-arm`` runs and what the in-process benchmarks run against the
simulated driver (``nodes.bench.sim_arm``), so both take the same path. Per tick it judges
whether the arm can move (``nodes.arm.readiness``), drives an unlock when one was asked for
(``nodes.arm.unlock``), and hands out the commands the controller's playback yields
(``nodes.arm.commands``):

* The controller starts from the measured joints, and starts again from them whenever the arm
  has stood still for a reason of the robot's (a protective stop, the program stopped, joint
  states lost): the command then continues from where the arm is, never from where it was
  told to be before it stopped.
* While the arm cannot move nothing is sent and setpoints are refused (each refusal counted,
  the reason returned). Paused (the slider at 0), setpoints queue on the stream and the arm
  waits on its path.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from msgs_py.status import ArmStatus
from nodes.arm.commands import JointStreamer, TrajectorySnippet
from nodes.arm.config import ArmConfig
from nodes.arm.controller import ArmController, SetpointResult
from nodes.arm.readiness import ArmState, DriverState, judge, percent_to_fraction
from nodes.arm.unlock import UnlockSequence
from nodes.common.joints import values_by_name
from nodes.robot import ur10e
from nodes.robot.kinematics import tcp_pose

#: Setpoints are taken in these states (paused: they wait on the stream).
TAKES_SETPOINTS = ("ready", "paused")


@dataclass
class ArmOutputs:
    """What to send after a tick."""

    trajectory: TrajectorySnippet | None = None
    positions: np.ndarray | None = None
    dashboard_calls: list[str] = field(default_factory=list)
    log: list[str] = field(default_factory=list)


class ArmCore:
    def __init__(self, cfg: ArmConfig) -> None:
        self.cfg = cfg
        self.controller = ArmController(np.zeros(6), cfg.min_tcp_z, cfg.speed_scale,
                                        cfg.servo_delay_s)
        self.streamer = JointStreamer(self.controller, 1.0 / cfg.control_rate_hz,
                                      cfg.horizon_s, cfg.point_spacing_s)
        self.driver = DriverState()
        self.q: np.ndarray | None = None  #: the measured joints (kinematic order, rad)
        self.joints_stamp: float | None = None
        self.missing: tuple[str, ...] = ()
        self.state = ArmState("no_joint_states", "no /joint_states received yet")
        self.unlock: UnlockSequence | None = None
        self._call_pending: str | None = None
        self._synced = False  # the controller starts from the measured joints

    # --- inputs ---------------------------------------------------------------------------------
    def on_joint_state(self, names: Sequence[str], positions: Sequence[float],
                       stamp_s: float) -> np.ndarray | None:
        """A joint state, read by name; returns the TCP pose (4x4, world) it puts the tool at,
        or None when it lacks an arm joint. One that names no arm joint at all is another
        driver's on the same topic (a gripper's, say) and is ignored."""
        if not set(names) & set(ur10e.ARM_JOINTS):
            return None
        q, self.missing = values_by_name(names, positions, ur10e.ARM_JOINTS)
        if self.missing or q is None:
            return None
        self.q, self.joints_stamp = q, stamp_s
        return tcp_pose(q)

    def on_safety_mode(self, code: int) -> None:
        self.driver = dataclasses.replace(self.driver, safety_mode=int(code))

    def on_robot_mode(self, code: int) -> None:
        self.driver = dataclasses.replace(self.driver, robot_mode=int(code))

    def on_program_running(self, running: bool) -> None:
        self.driver = dataclasses.replace(self.driver, program_running=bool(running))

    def on_speed_scaling(self, percent: float) -> None:
        fraction = percent_to_fraction(percent)
        self.driver = dataclasses.replace(self.driver, speed_scaling=fraction)
        self.controller.set_speed_scaling(fraction)

    def on_setpoint(self, position, quat_xyzw, frame_id: str, stamp_s: float | None
                    ) -> SetpointResult:
        if self.state.state not in TAKES_SETPOINTS or not self._synced:
            self.controller.rejected += 1
            return SetpointResult(False, f"the arm is not ready: {self.state.reason}")
        result = self.controller.set_setpoint(position, quat_xyzw, frame_id, stamp_s)
        if result.accepted:
            self.streamer.on_setpoint(stamp_s)
        return result

    def request_unlock(self, now: float) -> tuple[bool, str]:
        """Someone (the executor) asks to get out of a protective stop."""
        if self.unlock is not None:
            return True, "unlocking: already under way"
        if self.state.state != "protective_stop":
            return False, f"not in a protective stop ({self.state.state})"
        self.unlock = UnlockSequence(now, self.cfg.program_timeout_s)
        self._call_pending = None
        return True, ("unlocking: close_safety_popup, unlock_protective_stop, stop, play, then "
                      "waiting for the program to run")

    def on_dashboard_answer(self, call: str, success: bool, message: str, now: float) -> None:
        if call == self._call_pending:
            self._call_pending = None
        if self.unlock is not None:
            self.unlock.on_answer(call, success, message, now)

    # --- the tick -------------------------------------------------------------------------------
    def tick(self, now: float) -> ArmOutputs:
        out = ArmOutputs()
        self._drive_unlock(now, out)
        age = None if self.joints_stamp is None else now - self.joints_stamp
        state = judge(self.driver, age, self.missing, self.cfg.joint_state_timeout_s,
                      unlocking=self.unlock is not None)
        if state != self.state:
            out.log.append(f"arm {state.state}" + (f": {state.reason}" if state.reason else ""))
            self.state = state
        if state.state not in TAKES_SETPOINTS:
            self._synced = False  # when it can move again, start from where it stands
            return out
        if not self._synced and self.q is not None:
            self.streamer.reset(self.q, now)
            scaling = self.driver.speed_scaling
            self.controller.set_speed_scaling(1.0 if scaling is None else scaling)
            self._synced = True
        period = 1.0 / self.cfg.command_rate_hz
        if self.cfg.command_interface == "trajectory":
            out.trajectory = self.streamer.snippet(now)
        else:
            out.positions = self.streamer.position(now, period)
        return out

    def _drive_unlock(self, now: float, out: ArmOutputs) -> None:
        seq = self.unlock
        if seq is None:
            return
        seq.on_program_running(bool(self.driver.program_running), now)
        seq.on_timeout(now, self.cfg.dashboard_timeout_s)
        call = seq.next_call()
        if call is not None and self._call_pending is None:
            self._call_pending = call
            out.dashboard_calls.append(call)
        if seq.finished:
            out.log.append("protective stop unlocked, the program runs again" if seq.done
                           else f"unlock failed: {seq.failure}")
            self.unlock = None
            self._call_pending = None

    def status(self, stamp_ns: int) -> ArmStatus:
        d = self.driver
        return ArmStatus(
            self.state.state, self.state.reason,
            1.0 if d.speed_scaling is None else d.speed_scaling, bool(d.program_running),
            0 if d.safety_mode is None else d.safety_mode,
            -128 if d.robot_mode is None else d.robot_mode,
            self.controller.stream_time if self._synced else None,
            self.controller.rejected, stamp_ns)
