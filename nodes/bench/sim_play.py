"""Play executor step scripts on a simulated cell, no ROS: 50 Hz ticks, stamped setpoints, the
gripper's commands and reports, as the executor node exchanges them with the arm and gripper
nodes (here ``SimArm``: the arm node's logic in front of a ``SimWorld``), for the sim tests and
``densepack-bench placement``."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from nodes.bench.sim_arm import SimArm
from nodes.common.transforms import quaternion_to_matrix, tool_down_quaternion, yaw_of_matrix
from nodes.executor.config import ExecutorConfig
from nodes.executor.motion import ToolPose
from nodes.executor.steps import Step, StepFaultKind, StepRunner


def tool_pose(world: SimArm) -> ToolPose:
    p, q = world.tcp_pose()
    return ToolPose(*p, yaw_of_matrix(quaternion_to_matrix(q)))


def commanded_pose(world: SimArm) -> ToolPose:
    """Where the arm was last told to go: a script starts there, as the executor's does (not
    from the measured TCP, which lags the stream: starting there would turn it back)."""
    t = world.commanded_tcp()
    return ToolPose(*t[:3, 3], yaw_of_matrix(t[:3, :3]))


def play(world: SimArm, steps: Sequence[Step], cfg: ExecutorConfig,
         on_label: Callable[[SimArm, str], None] = lambda w, label: None,
         on_tick: Callable[[SimArm], None] = lambda w: None,
         on_stall: Callable[[SimArm, StepRunner], None] | None = None,
         limit_s: float = math.inf) -> tuple[StepRunner, str]:
    """Run ``steps`` to their end, or to the first error; (the runner, the error or "").

    ``on_label`` is called when a new step starts, ``on_tick`` every tick (fault injection,
    measurements). A stalled opening goes to ``on_stall`` (which may ``retry_current``), or
    is an error without it. ``limit_s`` of simulated time not finished is an error too."""
    runner = StepRunner(steps, commanded_pose(world), cfg.convergence_tol,
                        cfg.convergence_timeout_s, cfg.in_safe_box)
    period = round(world.config.physics_rate_hz / cfg.rate_hz)
    t_end = world.time_s + limit_s
    label = None
    while not runner.finished:
        if world.time_s > t_end:
            return runner, f"not finished in {limit_s:.0f} s"
        now = world.time_s
        tick = runner.update(now, tool_pose(world), now, [(now, world.fingers.gap())])
        stalled = tick.fault is not None and tick.fault.kind is StepFaultKind.STALLED
        if stalled and on_stall is not None:
            on_stall(world, runner)
            continue
        if tick.error:
            return runner, tick.error
        if tick.gripper is not None:
            world.set_gripper(tick.gripper)
        sp = tick.setpoint
        world.set_setpoint([sp.x, sp.y, sp.z], tool_down_quaternion(sp.yaw), stamp_s=now)
        if tick.label != label:
            label = tick.label
            on_label(world, label)
        on_tick(world)
        world.step(period)
    return runner, ""
