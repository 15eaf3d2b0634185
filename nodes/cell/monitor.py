"""What a run report needs, collected from a running cell's topics and its goal."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from densepack_interfaces.action import Rearrange
from densepack_interfaces.msg import BlockPoseArray, ExecutorStatus, SimEvents
from densepack_interfaces.msg import Plan as PlanMsg
from densepack_interfaces.msg import PlannerStatus as PlannerStatusMsg
from rclpy.action import ActionClient
from rclpy.node import Node
from sensor_msgs.msg import Image
from std_srvs.srv import Trigger

from msgs_py import BlockSet, MessageError, Plan
from msgs_py.ros import (
    block_set_from_msg,
    executor_status_from_msg,
    plan_from_msg,
    planner_status_from_msg,
    sim_events_from_msg,
    stamp_to_ns,
)
from nodes.cell.timeline import TimelineBuilder
from nodes.common.qos import LATCHED, RELIABLE, SENSOR
from nodes.common.transports import own_profile


class RunMonitor:
    """The latest of everything a run report needs, from the cell's topics and the goal."""

    def __init__(self, context: Any) -> None:
        # its participant announces itself as often as the nodes' do (``own_profile``): the
        # run waits until it sees every node, and one that missed its first announcement
        # otherwise met it 3 s later
        with own_profile():
            self.node = Node("densepack_run", context=context)
        self.lock = threading.Lock()
        self.executor_status: Any = None
        self.planner_status: Any = None
        self.plans: list[Plan] = []
        self.events: Any = None  # msgs_py.sim.SimEvents
        self.ground_truth: BlockSet | None = None
        self.detection: BlockSet | None = None
        self.feedback: Any = None  # msgs_py.tasks.RearrangeFeedback of the goal
        self.result: Any = None  # msgs_py.tasks.RearrangeResult of the goal
        self.first_image: Any = None
        self.last_image: Any = None
        self.sim_time = 0.0
        #: the simulated time when the goal's result came (None: not yet): the run's cycle
        #: time; ``sim_time`` goes on while the last ground truth and events settle
        self.ended_at: float | None = None
        self.since_ns = 0  # detections, ground truth and events stamped before are not this goal's
        # When data last came from the nodes heard steadily (time.monotonic(); None: not yet):
        # on another computer, their silence says the link is down (nodes/cell/discovery.py).
        self.heard: dict[str, float | None] = {"sim": None}
        # Per-action spans for the report's timeline, from the status stream as it comes.
        self.timeline = TimelineBuilder()
        n = self.node
        n.create_subscription(ExecutorStatus, "/executor/status", self._on_executor_status,
                              LATCHED)
        n.create_subscription(PlannerStatusMsg, "/planner/status",
                              self._keep("planner_status", planner_status_from_msg),
                              LATCHED)
        n.create_subscription(PlanMsg, "/plan", self._keep("plans", plan_from_msg),
                              LATCHED)
        n.create_subscription(BlockPoseArray, "/sim/ground_truth",
                              self._keep("ground_truth", block_set_from_msg), RELIABLE)
        n.create_subscription(BlockPoseArray, "/blocks/detected",
                              self._keep("detection", block_set_from_msg), RELIABLE)
        n.create_subscription(SimEvents, "/sim/events",
                              self._keep("events", sim_events_from_msg), LATCHED)
        n.create_subscription(Image, "/camera/image_raw", self._on_image, SENSOR)

        # Simulated time comes from the ground truth's stamps (10 Hz), not /clock: a /clock
        # subscription costs a Python callback per message.
        self.rearrange = ActionClient(n, Rearrange, "/rearrange")
        # One for the monitor's life, used by every goal's run: a client made per goal (as
        # it was) left one more service client, with its DDS reader and writer, on the graph
        # each goal: over a 200-goal shift the benchmark's CPU per goal grew 2.5-fold and
        # every process's discovery data with it.
        self.sim_start = n.create_client(Trigger, "/sim/start")

    def begin_goal(self, since_ns: int) -> None:
        """Forget the last goal (several goals on one cell): its plans, feedback, result,
        timeline and images; detections, ground truth and events stamped before ``since_ns``
        (when a new scene was laid out) are the last scene's and are not kept."""
        with self.lock:
            self.plans, self.feedback, self.result = [], None, None
            self.events = self.ground_truth = self.detection = None
            self.first_image = self.last_image = None
            self.timeline = TimelineBuilder()
            self.since_ns = since_ns
            self.ended_at = None

    def goal_ended(self) -> None:
        """The goal's result came: its simulated time is the run's (the last ground truth's
        stamp, at most one of its periods early)."""
        with self.lock:
            self.ended_at = self.sim_time

    def settled(self, after_s: float) -> bool:
        """Whether a ground truth stamped ``after_s`` of simulated time past the goal's end
        has come (the blocks' final poses and the sim's last events are in)."""
        with self.lock:
            return self.ended_at is not None and self.sim_time >= self.ended_at + after_s

    @property
    def run_time(self) -> float:
        """The simulated time the goal took to its result (without a result: so far)."""
        with self.lock:
            return self.sim_time if self.ended_at is None else self.ended_at

    def _keep(self, attr: str, decode: Callable[[Any], Any]) -> Callable[[Any], None]:
        def callback(msg: Any) -> None:
            try:
                value = decode(msg)
            except (MessageError, ValueError):
                return  # a malformed message is not the monitor's business
            with self.lock:
                if attr == "ground_truth":
                    self.heard["sim"] = time.monotonic()
                if getattr(value, "stamp_ns", self.since_ns) < self.since_ns:
                    return  # the last scene's
                if attr == "ground_truth":
                    self.sim_time = value.stamp_ns * 1e-9
                if attr == "plans":
                    if not self.plans or self.plans[-1].plan_id != value.plan_id:
                        self.plans.append(value)
                        self.timeline.add_plan(value.plan_id, [a.type for a in value.actions])
                else:
                    setattr(self, attr, value)

        return callback

    def _on_executor_status(self, msg: Any) -> None:
        try:
            status = executor_status_from_msg(msg)
        except (MessageError, ValueError):
            return
        with self.lock:
            self.executor_status = status
            # The executor stamps its status with its simulated clock.
            self.timeline.on_status(stamp_to_ns(msg.stamp) * 1e-9, status.state, status.plan_id,
                                    status.action_index, status.action_total, status.block)

    def _on_image(self, msg: Any) -> None:
        with self.lock:
            if self.first_image is None:
                self.first_image = msg
            self.last_image = msg


#: Topics only a running cell publishes (by the node that does): seen on the domain, another
#: cell is there.
CELL_TOPICS = {"sim": "/sim/ground_truth", "executor": "/executor/status", "planner": "/plan"}


def another_cell(node: Any, wait_s: float = 2.0, remote: Sequence[str] = ()) -> str | None:
    """The topic through which another cell shows itself on this node's domain, or None.
    Two cells on one domain hear each other's goals, detections and plans. The topics of
    ``remote`` nodes (this cell's, on another computer) do not count."""
    topics = [t for name, t in CELL_TOPICS.items() if name not in remote]
    deadline = time.monotonic() + wait_s
    while True:
        for topic in topics:
            if node.count_publishers(topic) > 0:
                return topic
        if time.monotonic() >= deadline:
            return None
        time.sleep(0.1)
