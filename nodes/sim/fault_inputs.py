"""The sim's fault injection inputs (``/sim/fault``, ``/sim/disturb``, ``/sim/camera_blackout``):
validated in the callback, applied by the sim loop like every command; a refused one is logged
and changes nothing."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from densepack_interfaces.msg import Disturbance, SimFault
from std_msgs.msg import Float64

from msgs_py import MessageError
from msgs_py import ros as msg_codecs
from nodes.common.qos import RELIABLE


class FaultInputs:
    """Subscribes the fault topics on ``node``; ``queue`` hands a command to the sim loop,
    ``world`` gives the world it then acts on."""

    def __init__(self, node: Any, world: Callable[[], Any],
                 queue: Callable[[Callable[[], None]], None], group: Any) -> None:
        self.node, self.world, self.queue = node, world, queue
        self.blackout_until_ns = 0  #: frames stamped before this are dropped (a fault)
        node.create_subscription(SimFault, "/sim/fault", self._on_fault, RELIABLE,
                                 callback_group=group)
        node.create_subscription(Disturbance, "/sim/disturb", self._on_disturb, RELIABLE,
                                 callback_group=group)
        node.create_subscription(Float64, "/sim/camera_blackout", self._on_blackout, RELIABLE,
                                 callback_group=group)

    def _on_disturb(self, msg: Disturbance) -> None:
        try:
            nudge = msg_codecs.disturbance_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.node.get_logger().warning(f"/sim/disturb refused: {err}")
            return

        def apply() -> None:
            try:
                self.world().hand.disturb(nudge.block, nudge.dx, nudge.dy)
            except ValueError as err:
                self.node.get_logger().warning(f"/sim/disturb refused: {err}")
        self.queue(apply)

    def _on_fault(self, msg: SimFault) -> None:
        """Fault injection: arm a drop, slip or miss for the next action, take a block out,
        put one in, or change the camera's noise."""
        try:
            fault = msg_codecs.sim_fault_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.node.get_logger().warning(f"/sim/fault refused: {err}")
            return

        def apply() -> None:
            try:
                self.world().hand.inject(fault)
            except ValueError as err:
                self.node.get_logger().warning(f"/sim/fault refused: {err}")
                return
            self.node.get_logger().warning(f"fault injected: {fault.kind} "
                                      f"{'' if fault.block is None else fault.block}")
        self.queue(apply)

    def _on_blackout(self, msg: Float64) -> None:
        """Fault injection: drop every camera frame for the next ``msg.data`` sim seconds."""
        seconds = float(msg.data)
        if not math.isfinite(seconds) or seconds < 0:
            self.node.get_logger().warning(f"/sim/camera_blackout refused: {seconds} s")
            return

        def apply() -> None:
            self.blackout_until_ns = self.world().time_ns + round(seconds * 1e9)
            self.node.get_logger().warning(f"camera frames dropped for {seconds:.1f} s (fault)")
        self.queue(apply)

