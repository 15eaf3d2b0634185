"""The ``/rearrange`` action server (densepack_interfaces/action/Rearrange) of the executor.

It lives in the executor's process because what the action reports and does is the
executor core's: its state, action k of n, replans, the final detection, and the safe stop a
cancel asks for (``ExecutorCore.request_stop``). A goal is a goal layout:

* checked when it comes (msgs_py refuses NaN, overlapping slots, duplicate ids, slots outside
  its workspace; ``goals.check_layout`` a workspace out of the arm's reach and, against the
  latest detection, unknown ids and more slots than blocks) and rejected with the reason
  logged, since an action server cannot put a reason into a rejection (an executor that has
  not seen a detection yet, just restarted, leaves the id checks to the planner);
* rejected, too, while another goal runs or the executor is busy with a plan of its own: goals
  are not preempted (cancel first; a cancel is a safe stop);
* accepted: the layout goes to the planner on ``/goal_layout`` (latched, as ``densepack-goal``
  sends it), the core is started once the plan made for it arrives, and feedback follows the
  core's status (on every change, and at least once a second so a client can tell a live goal
  from one whose server died);
* canceled: ``request_stop()`` (the arm lifts and parks), and the result CANCELED once the core
  reports ``stopped``.

rclpy (Jazzy) runs a goal as one callback that must not return before the goal ends, and
re-polls an awaiting coroutine without sleeping; so the action server gets its own small node
(``<executor>/rearrange``) and a two-thread executor of its own: one thread waits out a goal,
the other answers goal, cancel and result requests. The executor's streaming node keeps its
single-threaded executor (a MultiThreadedExecutor costs about three times the CPU per callback).
"""

from __future__ import annotations

import threading
import time

from densepack_interfaces.action import Rearrange
from densepack_interfaces.msg import GoalLayout
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from msgs_py import BlockSet, MessageError, PlannerStatus
from msgs_py.ros import (
    goal_layout_to_msg,
    rearrange_feedback_to_msg,
    rearrange_goal_from_msg,
    rearrange_result_to_msg,
)
from msgs_py.tasks import RearrangeResult
from nodes.common.executors import PatientExecutor
from nodes.common.qos import LATCHED
from nodes.executor.config import ExecutorConfig
from nodes.executor.core import ExecutorCore
from nodes.executor.goals import BUSY_STATES, GoalRun, block_errors, check_layout

#: How often a running goal looks at the core (s, wall time).
POLL_S = 0.1
#: Feedback goes out at least this often while a goal runs (s).
HEARTBEAT_S = 1.0


class RearrangeServer:
    """``/rearrange`` beside ``node`` (it publishes the goal layout and names the server's
    own node), for ``core``, whose every use holds ``core_lock``; ``cfg`` gives the arm's
    box and how long to wait for a plan."""

    def __init__(self, node: Node, core: ExecutorCore, core_lock: threading.Lock,
                 cfg: ExecutorConfig) -> None:
        self.node = node
        self.core, self.core_lock, self.cfg = core, core_lock, cfg
        self.log = node.get_logger()
        self._lock = threading.Lock()  # guards the fields below; taken before core_lock
        self._busy = False  # a goal accepted and not finished
        self._run: GoalRun | None = None
        self._detection: BlockSet | None = None
        self._closing = threading.Event()
        self.goal_pub = node.create_publisher(GoalLayout, "/goal_layout", LATCHED)
        namespace = node.get_fully_qualified_name()
        self.helper = Node("rearrange", namespace=namespace, context=node.context,
                           use_global_arguments=False, start_parameter_services=False)
        self.server = ActionServer(
            self.helper, Rearrange, "/rearrange", execute_callback=self._execute,
            goal_callback=self._on_goal, cancel_callback=self._on_cancel,
            callback_group=ReentrantCallbackGroup())
        self.executor = PatientExecutor(num_threads=2, context=node.context)
        self.executor.add_node(self.helper)
        self._thread = threading.Thread(target=self._spin, name="rearrange", daemon=True)
        self._thread.start()

    # --- inputs from the executor node ----------------------------------------------------------
    def on_detection(self, detection: BlockSet) -> None:
        with self._lock:
            self._detection = detection

    def on_planner_status(self, status: PlannerStatus) -> None:
        with self._lock:
            if self._run is not None:
                self._run.on_planner_status(status)

    # --- goal, cancel ---------------------------------------------------------------------------
    def _on_goal(self, request: Rearrange.Goal) -> GoalResponse:
        try:
            layout = rearrange_goal_from_msg(request)
        except MessageError as err:
            return self._reject(str(err))
        with self._lock:
            if self._busy:
                return self._reject("another goal is running (goals are not preempted: cancel "
                                    "it first)")
            with self.core_lock:
                status = self.core.status()
            if status.state in BUSY_STATES:
                return self._reject(f"the executor is busy ({status.state}: {status.detail}); "
                                    "stop it first")
            try:
                check_layout(layout, self._detection, self.cfg.safe_box)
            except MessageError as err:
                return self._reject(str(err))
            if self._detection is None:
                self.log.warning("/rearrange goal accepted before any detection: its block ids "
                                 "are left to the planner to check")
            self._busy = True
        return GoalResponse.ACCEPT

    def _reject(self, reason: str) -> GoalResponse:
        self.log.warning(f"/rearrange goal rejected: {reason}")
        return GoalResponse.REJECT

    def _on_cancel(self, handle) -> CancelResponse:
        self.log.info("/rearrange: cancel requested; stopping safely")
        return CancelResponse.ACCEPT

    # --- a running goal -------------------------------------------------------------------------
    def _execute(self, handle) -> Rearrange.Result:
        try:
            result = self._follow(handle)
        except Exception as err:  # never leave a client waiting on a goal that went wrong
            self.log.error(f"/rearrange goal failed: {type(err).__name__}: {err}")
            result = RearrangeResult("failed", f"{type(err).__name__}: {err}")
        finally:
            with self._lock:
                self._busy, self._run = False, None
        {"succeeded": handle.succeed, "canceled": handle.canceled}.get(
            result.outcome, handle.abort)()
        self.log.info(f"/rearrange goal {result.outcome}: {result.detail}")
        return rearrange_result_to_msg(result)

    def _follow(self, handle) -> RearrangeResult:
        """Send the layout to the planner, start the core on its plan, report, finish."""
        core, lock = self.core, self.core_lock
        layout = rearrange_goal_from_msg(handle.request)
        with lock:
            before = core.plan.plan_id if core.plan is not None else ""
        run = GoalRun(layout, before, time.monotonic(), self.cfg.replan_timeout_s)
        with self._lock:
            self._run = run
        self.goal_pub.publish(goal_layout_to_msg(layout,
                                                self.node.get_clock().now().nanoseconds))
        self.log.info(f"/rearrange goal accepted: {layout.goal.n_slots} slots; goal layout "
                      "sent to the planner")
        reported = -HEARTBEAT_S
        while True:
            if self._closing.is_set():
                return RearrangeResult("failed", "the executor is shutting down")
            if handle.is_cancel_requested and not run.cancel_requested:
                run.cancel()
                with lock:
                    core.request_stop()
            with lock:
                status, plan = core.status(), core.plan
            with self._lock:
                step = run.update(status, plan, time.monotonic())
            if step.start:
                with lock:
                    core.request_start()
            now = time.monotonic()
            if run.changed(step.feedback) or now - reported >= HEARTBEAT_S:
                handle.publish_feedback(rearrange_feedback_to_msg(step.feedback))
                reported = now
            if step.outcome:
                break
            self._closing.wait(POLL_S)
        with self._lock:
            detection = self._detection
        metrics = dict(status.metrics, corrections=float(step.feedback.corrections))
        errors = block_errors(detection, plan if run.plan_id else None)
        return RearrangeResult(step.outcome, step.detail, errors, metrics)

    # --- lifecycle ------------------------------------------------------------------------------
    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception as err:  # the context shut down under it: nothing left to serve
            if self.node.context.ok():
                self.log.error(f"/rearrange server stopped: {type(err).__name__}: {err}")

    def close(self) -> None:
        self._closing.set()
        self.executor.shutdown(timeout_sec=5.0)
        self._thread.join(timeout=5.0)
        self.server.destroy()
        self.helper.destroy_node()
