"""PatientExecutor: a spin returns only once the workers have started the callbacks it handed
them (Jazzy's MultiThreadedExecutor returns at once; its spinning thread then loops on them,
holding the GIL the workers need to start them)."""

from __future__ import annotations

import pytest
import rclpy
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

from nodes.common.executors import PatientExecutor

pytestmark = pytest.mark.ros

SPINS = 300


def spins_leaving_callbacks_unstarted(executor_type) -> int:
    """Of SPINS spins over four always-due timers, how many returned with a callback handed
    to a worker and not yet started."""
    context = Context()
    rclpy.init(context=context)
    executor = executor_type(num_threads=4, context=context)
    node = Node("handouts", context=context)
    for _ in range(4):
        node.create_timer(0.0005, lambda: sum(range(2000)), MutuallyExclusiveCallbackGroup())
    executor.add_node(node)
    try:
        unstarted = 0
        for _ in range(SPINS):
            executor.spin_once(timeout_sec=0.05)
            unstarted += any(not (task.executing() or task.done())
                             for task in list(executor._futures))
        return unstarted
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def test_a_spin_returns_once_the_workers_have_started_what_it_handed_them():
    stock = spins_leaving_callbacks_unstarted(MultiThreadedExecutor)
    patient = spins_leaving_callbacks_unstarted(PatientExecutor)
    assert patient < SPINS // 10 < stock, (patient, stock)
