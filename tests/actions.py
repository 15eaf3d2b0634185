"""Rearrange goals sent from a test's harness node, with their feedback (shared by the node,
tool and end-to-end tests)."""

from __future__ import annotations

import time

from densepack_interfaces.action import Rearrange
from rclpy.action import ActionClient

from msgs_py import ros as msg_codecs
from nodes.common.harness import wait_for_future


def wait_future(future, what: str, timeout: float = 30.0):
    """The result of an rclpy future that the harness spins."""
    return wait_for_future(future, what, timeout)


class Goals:
    """A Rearrange client on the harness's probe node; ``feedback`` collects every feedback
    message of every goal sent, decoded."""

    def __init__(self, ros, name: str = "/rearrange", timeout: float = 30.0) -> None:
        self.client = ActionClient(ros.probe, Rearrange, name)
        assert self.client.wait_for_server(timeout_sec=timeout), f"no Rearrange server {name}"
        self.timeout = timeout
        self.feedback: list = []

    def send(self, goal: Rearrange.Goal):
        future = self.client.send_goal_async(
            goal, feedback_callback=lambda fb: self.feedback.append(
                msg_codecs.rearrange_feedback_from_msg(fb.feedback)))
        return wait_future(future, "send_goal", self.timeout)

    def result(self, handle, timeout: float):
        """(GoalStatus status, decoded RearrangeResult) of an accepted goal."""
        answer = wait_future(handle.get_result_async(), "result", timeout)
        return answer.status, msg_codecs.rearrange_result_from_msg(answer.result)

    def wait_feedback(self, predicate, timeout: float):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for fb in list(self.feedback):
                if predicate(fb):
                    return fb
            time.sleep(0.02)
        raise TimeoutError(f"no matching feedback in {timeout} s; got {self.feedback[-3:]}")
