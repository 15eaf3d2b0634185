"""A ``SimWorld`` driven through the arm node's own logic, in one process, no ROS.

What ``densepack-arm`` and the sim node exchange over DDS, ``SimArm`` hands over in calls:
each ``command_rate_hz`` tick it feeds the world's joint states and driver state to an
``ArmCore`` (the arm node's logic), sends the joint trajectory snippet it yields to the world's
trajectory controller, and answers its dashboard calls from the world's dashboard. Cartesian
setpoints and gripper gaps go in as the executor sends them (a gap becomes the knuckle command
the gripper node would send). For the sim tests and the in-process benchmarks, which play
executor scripts on a world: they exercise the same IK, playback and command path as the cell.

Everything else is the world's: attribute access falls through to it, so a ``SimArm`` stands
wherever a ``SimWorld`` was read (``block_poses``, ``monitor``, ``render`` ...). Step it with
``SimArm.step``, never the world's own ``step``, or the arm gets no commands.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nodes.arm.config import ArmConfig
from nodes.arm.controller import SetpointResult
from nodes.arm.core import ArmCore
from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e
from nodes.sim.world import SimWorld


class SimArm:
    """A world plus the arm node's logic in front of it."""

    def __init__(self, world: SimWorld, cfg: ArmConfig | None = None) -> None:
        self.world = world
        self.cfg = cfg or ArmConfig()
        self.core = ArmCore(self.cfg)
        self.period = 1.0 / self.cfg.command_rate_hz
        self._next_tick = world.time_s
        self.refusals: list[str] = []  #: commands the world's controllers refused
        self.log: list[str] = []  #: what the arm node would log
        self.tick()  # judged the driver: ready for setpoints
        self._next_tick += self.period

    def __getattr__(self, name: str) -> Any:
        return getattr(self.world, name)

    # --- what the executor sends --------------------------------------------------------------
    def set_setpoint(self, position, quat_xyzw, frame_id: str = "world",
                     stamp_s: float | None = None) -> SetpointResult:
        stamp = self.world.time_s if stamp_s is None else stamp_s
        return self.core.on_setpoint(position, quat_xyzw, frame_id, stamp)

    def set_gripper(self, gap: float) -> float:
        """The executor's gap, as the gripper node sends it to the Robotiq driver."""
        return self.world.fingers.set_knuckle(g85.gap_to_knuckle(gap))

    def unlock_protective_stop(self) -> tuple[bool, str]:
        return self.core.request_unlock(self.world.time_s)

    # --- time -----------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """``n`` physics steps, the arm node ticking at its command rate between them."""
        for _ in range(n):
            if self.world.time_s + 1e-9 >= self._next_tick:
                self.tick()
                self._next_tick += self.period
            self.world.step()

    def tick(self) -> None:
        """One tick of the arm node: read the driver, command the arm."""
        self._feed()
        now = self.world.time_s
        out = self.core.tick(now)
        self.log.extend(out.log)
        for call in out.dashboard_calls:
            answer = self.world.dashboard(call)
            self.core.on_dashboard_answer(call, answer.success, answer.message, now)
        if out.trajectory is not None:
            self._refused(self.world.command_trajectory(
                ur10e.ARM_JOINTS, out.trajectory.start_s, out.trajectory.as_points()))
        if out.positions is not None:
            self._refused(self.world.command_positions(out.positions.tolist()))

    def _refused(self, error: str) -> None:
        if error:
            self.refusals.append(error)

    def _feed(self) -> None:
        names, q, _ = self.world.joint_state()
        self.core.on_joint_state(names, q, self.world.time_s)
        state = self.world.robot_state
        self.core.on_safety_mode(state.safety_mode)
        self.core.on_robot_mode(state.robot_mode)
        self.core.on_program_running(state.program_running)
        self.core.on_speed_scaling(100.0 * state.speed_scaling)

    def commanded_tcp(self) -> np.ndarray:
        """The TCP pose (4x4) the arm is commanded to reach last."""
        return self.core.controller.target_tcp()
