"""``densepack-planner``: plans from the latest detection to the goal layout, each plan in a
process of its own (``child_process``: the node's memory stays flat goal after goal).

Subscribes ``/blocks/detected`` (BlockPoseArray) and ``/goal_layout`` (GoalLayout, latched);
publishes ``/plan`` (Plan, latched), ``/plan/markers`` (MarkerArray, latched) and
``/planner/status`` (PlannerStatus, latched), all ``densepack_interfaces`` but the markers;
serves ``/planner/replan`` (std_srvs/Trigger) and ``/plan_scene`` (PlanScene: a scene in, a
validated plan or a refusal naming the block, the reason and the field out; nothing is
published). It plans once automatically as soon as it has a goal layout and a detection
that shows every block (a block listed as ``missing`` is occluded: it waits for the next
detection and says so). A bad goal or detection is reported on the log and in the status.
Every goal kind is planned (``dispatch.plan_goal``): labeled with pIRS, unlabeled and
retrieval (a labeled goal naming only some blocks) with rearrangement pebble graphs.
"""

from __future__ import annotations

import math
import re
import sys
import threading
import uuid
from collections.abc import Callable
from typing import Any

from densepack_interfaces.msg import BlockPoseArray, GoalLayout
from densepack_interfaces.msg import Plan as PlanMsg
from densepack_interfaces.msg import PlannerStatus as PlannerStatusMsg
from densepack_interfaces.srv import PlanScene
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import BlockSet, MessageError, PlannerStatus, Scene
from msgs_py.cell import TABLE_MARGIN
from msgs_py.poses import yaw_difference
from msgs_py.ros import (
    block_set_from_msg,
    goal_layout_from_msg,
    plan_reply_to_msg,
    plan_request_from_msg,
    plan_to_msg,
    planner_status_to_msg,
)
from msgs_py.tasks import PlanReply, PlanRequest
from nodes.common.params import config_overrides, configs_from_parameters, declare_config
from nodes.common.qos import LATCHED, RELIABLE
from nodes.common.runner import NodeSpec, run_node
from nodes.planner.child_process import ChildRunner, PlanningProcessDied
from nodes.planner.cli import PLANNER_PARAMETERS
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import check_goal, goal_kind, plan_goal, pulled_inside
from nodes.planner.markers import plan_markers
from nodes.planner.outcome import PlanOutcome
from nodes.planner.unlabeled.config import UnlabeledConfig


def scene_to_plan(layout: Scene, detection: BlockSet) -> tuple[Scene | None, str]:
    """The scene to plan, or (None, why we must wait). Raises MessageError when the goal and
    the detection cannot be combined (unseen blocks, overlaps, outside the workspace)."""
    if detection.missing:
        return None, (f"blocks {sorted(detection.missing)} are occluded in the last detection; "
                      "waiting for one that shows every block")
    if detection.occluded:  # a frame taken with the arm in view: its poses are not all there
        return None, (f"blocks {sorted(detection.occluded)} are covered by the arm in the last "
                      "detection; waiting for one that shows every block")
    check_goal(layout)
    seen = set(detection.ids)
    named = sorted(s.id for s in layout.goal.slots if s.id is not None)
    unseen = [b for b in named if b not in seen]
    if unseen:
        raise MessageError("goal.poses", unseen, f"the goal names blocks that were never "
                           f"detected (seen: {sorted(seen)})")
    return layout.with_blocks(pulled_inside(detection.blocks, layout, TABLE_MARGIN)), ""



#: A block this far from where it stood in the detection being planned from has moved.
MOVED_POS_M, MOVED_YAW_RAD = 0.001, math.radians(0.5)
#: Plans thrown away, at most, because a detection showed blocks moving while planning.
MAX_STALE_PLANS = 2


def moved_blocks(old: BlockSet, new: BlockSet) -> list[int]:
    """Blocks seen in ``new`` that moved (or appeared) since ``old``: a plan from ``old`` would
    not start where they stand. Noise (hundredths of a mm) is not movement."""
    before = {b.id: b.pose for b in old.blocks}
    moved = []
    for block in new.blocks:
        was = before.get(block.id)
        if was is None or was.distance_to(block.pose) > MOVED_POS_M or yaw_difference(
                was.theta, block.pose.theta, math.pi / 2) > MOVED_YAW_RAD:
            moved.append(block.id)
    return moved


def planner_configs(base: tuple[PlannerConfig, UnlabeledConfig], overrides: dict[str, Any]
                    ) -> tuple[PlannerConfig, UnlabeledConfig]:
    """``base`` with ``overrides`` (parameter name -> value) applied. Raises MessageError
    naming the first bad override as ``overrides[k]`` (unknown, mistyped, out of range)."""
    values = {**config_overrides(base[0]), **config_overrides(base[1], "unlabeled.")}
    for k, (name, value) in enumerate(overrides.items()):
        try:
            configs_from_parameters(PLANNER_PARAMETERS, {**values, name: value}, "override")
        except ValueError as err:
            raise MessageError(f"overrides[{k}]", name, str(err)) from None
        values[name] = value
    config, unlabeled = configs_from_parameters(PLANNER_PARAMETERS, values, "overrides")
    return config, unlabeled


def _failed_block(field: str, msg: PlanScene.Request) -> int | None:
    """The block a refused request's field belongs to (``scene.blocks[2].pose.x`` -> the id
    of that block), if it names one."""
    blocks = re.match(r"scene\.blocks\[(\d+)\]", field)
    if blocks and int(blocks.group(1)) < len(msg.scene.blocks):
        block = msg.scene.blocks[int(blocks.group(1))].id
        return int(block) if block >= 0 else None
    slots = re.match(r"scene\.goal\.slots\[(\d+)\]", field)
    if slots and int(slots.group(1)) < len(msg.scene.goal.slots):
        block = msg.scene.goal.slots[int(slots.group(1))].block_id
        return int(block) if block >= 0 else None
    return None


def answer_plan_request(msg: PlanScene.Request,
                        base: tuple[PlannerConfig, UnlabeledConfig],
                        should_stop: Callable[[], bool],
                        plan: Callable[..., PlanOutcome] = plan_goal) -> PlanReply:
    """A PlanScene request's reply: a validated plan, or a refusal naming the field.
    ``plan`` plans the scene (``plan_goal``, or the node's call of it in a process of its
    own)."""
    try:
        request: PlanRequest = plan_request_from_msg(msg)
    except MessageError as err:
        kind = "invalid_parameter" if err.field.startswith("overrides") else "invalid_scene"
        return PlanReply.refused(kind, f"{err.field}: {err.reason}",
                                 _failed_block(err.field, msg), err.field)
    try:
        config, unlabeled = planner_configs(base, request.overrides)
    except MessageError as err:
        return PlanReply.refused("invalid_parameter", f"{err.field} ({err.value}): {err.reason}",
                                 failed_field=err.field)
    try:
        check_goal(request.scene)
        outcome = plan(request.scene, config, unlabeled, uuid.uuid4().hex[:12],
                       should_stop=should_stop)
    except MessageError as err:
        field = f"scene.goal.{err.field}" if err.field in ("yaw_exact", "labeled") else \
            f"scene.{err.field}"
        return PlanReply.refused("invalid_scene", f"{field}: {err.reason}",
                                 _failed_block(field, msg), field)
    except ValueError as err:
        return PlanReply.refused("invalid_scene", str(err), failed_field="scene")
    except PlanningProcessDied as err:
        return PlanReply.refused("no_plan", str(err))
    if not outcome.ok:
        return PlanReply.refused("no_plan", outcome.error or "no plan found",
                                 outcome.failed_block)
    return PlanReply.planned(outcome.plan, f"{len(outcome.plan.actions)} actions in "
                             f"{outcome.planning_time_s:.2f} s (validated)")


class PlannerNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("planner", **kwargs)
        self.config = declare_config(self, PlannerConfig)
        self.unlabeled = declare_config(self, UnlabeledConfig, prefix="unlabeled.")
        self._lock = threading.Lock()
        self._layout: Scene | None = None
        self._detection: BlockSet | None = None
        self._auto_pending = True  # plan once by itself for each new goal layout
        self._worker: threading.Thread | None = None
        self._stop = threading.Event()  # set on shutdown: the worker gives up planning
        self._service_busy = threading.Lock()  # one PlanScene request at a time
        self._child = ChildRunner()  # each plan in a process of its own: a flat footprint
        self._child.warm_up()
        self.plan_pub = self.create_publisher(PlanMsg, "/plan", LATCHED)
        self.markers_pub = self.create_publisher(MarkerArray, "/plan/markers", LATCHED)
        self.status_pub = self.create_publisher(PlannerStatusMsg, "/planner/status", LATCHED)
        self.create_subscription(GoalLayout, "/goal_layout", self.on_goal, LATCHED)
        self.create_subscription(BlockPoseArray, "/blocks/detected", self.on_detection, RELIABLE)
        self.create_service(Trigger, "/planner/replan", self.on_replan)
        # Its own group: planning a scene takes seconds, the topics must not wait for it.
        self.create_service(PlanScene, "/plan_scene", self.on_plan_scene,
                            callback_group=MutuallyExclusiveCallbackGroup())
        self.status(PlannerStatus("waiting", last_error="no goal layout and no detection yet"))

    # --- callbacks ---------------------------------------------------------------------------
    def on_goal(self, msg: GoalLayout) -> None:
        try:
            layout = goal_layout_from_msg(msg)
            check_goal(layout)
        except (MessageError, ValueError) as err:
            self.get_logger().error(f"refused /goal_layout: {err}")
            self.status(PlannerStatus("failed", last_error=f"goal layout refused: {err}"))
            return
        with self._lock:
            self._layout, self._auto_pending = layout, True
        self.get_logger().info(f"goal layout: {layout.goal.n_slots} slots "
                               f"({goal_kind(layout)})")
        self.try_plan(auto=True)

    def on_detection(self, msg: BlockPoseArray) -> None:
        try:
            detection = block_set_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.get_logger().warning(f"ignoring a malformed /blocks/detected: {err}")
            return
        with self._lock:
            self._detection = detection
        self.try_plan(auto=True)

    def on_replan(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        response.success, response.message = self.try_plan(auto=False)
        return response

    def on_plan_scene(self, request: PlanScene.Request, response: PlanScene.Response
                      ) -> PlanScene.Response:
        """Plan a scene given in the request (offline, like densepack-plan): nothing is
        published, the node's goal layout and detection are not touched."""
        worker = self._worker
        if (worker is not None and worker.is_alive()) or not self._service_busy.acquire(
                blocking=False):
            reply = PlanReply.refused("busy", "the planner is planning; ask again later")
        else:
            try:
                reply = answer_plan_request(request, (self.config, self.unlabeled),
                                            self._stop.is_set, self._plan_in_child)
            finally:
                self._service_busy.release()
        if reply.success:
            self.get_logger().info(f"/plan_scene: {reply.message}")
        else:
            self.get_logger().warning(f"/plan_scene refused ({reply.error}): {reply.message}")
        try:
            return plan_reply_to_msg(reply)
        except MessageError as err:
            return plan_reply_to_msg(PlanReply.refused("no_plan", f"the plan cannot be sent: "
                                                       f"{err}"))

    # --- planning ----------------------------------------------------------------------------
    def try_plan(self, auto: bool) -> tuple[bool, str]:
        """Start planning on the worker thread if everything is there; (started, why)."""
        with self._lock:
            if self._worker is not None and self._worker.is_alive():
                return False, "already planning"
            if auto and not self._auto_pending:
                return False, "already planned for this goal; call /planner/replan"
            layout, detection = self._layout, self._detection
            if layout is None or detection is None:
                why = "waiting for " + " and ".join(
                    n for n, v in (("a goal layout", layout), ("a detection", detection))
                    if v is None)
                self.status(PlannerStatus("waiting", last_error=why))
                return False, why
            try:
                scene, wait = scene_to_plan(layout, detection)
            except (MessageError, ValueError) as err:
                self._auto_pending = False
                self.get_logger().error(f"cannot plan: {err}")
                self.status(PlannerStatus("failed", last_error=f"cannot plan: {err}"))
                return False, str(err)
            if scene is None:
                self.get_logger().info(wait)
                self.status(PlannerStatus("waiting", last_error=wait))
                return False, wait
            self._auto_pending = False
            self._worker = threading.Thread(target=self._plan, args=(scene, detection),
                                            daemon=True, name="planner-worker")
            self._worker.start()
        return True, "planning started"

    def destroy_node(self) -> None:
        self._stop.set()
        worker = self._worker
        if worker is not None and worker is not threading.current_thread():
            worker.join(timeout=5.0)
        super().destroy_node()

    def _plan(self, scene: Scene, detection: BlockSet) -> None:
        try:
            for _ in range(MAX_STALE_PLANS):
                fresher = self._plan_and_publish(scene, detection, may_discard=True)
                if fresher is None:
                    return
                scene, detection = fresher
            self._plan_and_publish(scene, detection, may_discard=False)
        except Exception as err:  # never let the worker die silently (e.g. during shutdown)
            if not self._stop.is_set():
                self.get_logger().error(f"planner worker failed: {type(err).__name__}: {err}")

    def _fresher_start(self, detection: BlockSet) -> tuple[Scene, BlockSet] | None:
        """A start newer than ``detection`` if blocks moved since it: a replan request can
        overtake the detection it was made for, and a plan from the older one would be
        refused by the executor (it does not start where the blocks stand)."""
        with self._lock:
            layout, newest = self._layout, self._detection
        if layout is None or newest is None or newest.stamp_ns <= detection.stamp_ns:
            return None
        moved = moved_blocks(detection, newest)
        if not moved:
            return None
        try:
            scene, _ = scene_to_plan(layout, newest)
        except (MessageError, ValueError):
            return None
        if scene is None:
            return None
        self.get_logger().info(f"blocks {moved} moved while planning; planning again from "
                               "the newer detection")
        return scene, newest

    def _plan_and_publish(self, scene: Scene, detection: BlockSet, may_discard: bool
                          ) -> tuple[Scene, BlockSet] | None:
        """Plan and publish the plan (or the failure); with ``may_discard``, return the
        fresher start instead when blocks moved while planning."""
        plan_id = uuid.uuid4().hex[:12]
        self.status(PlannerStatus("planning", plan_id=plan_id))
        try:
            outcome = self._plan_in_child(scene, self.config, self.unlabeled, plan_id,
                                          should_stop=self._stop.is_set)
        except (MessageError, ValueError, PlanningProcessDied) as err:
            self.get_logger().error(f"cannot plan: {err}")
            self.status(PlannerStatus("failed", plan_id=plan_id, last_error=str(err)))
            return None
        if self._stop.is_set():
            return None
        if may_discard and (fresher := self._fresher_start(detection)) is not None:
            return fresher
        if not outcome.ok:
            self.get_logger().error(f"no plan in {outcome.planning_time_s:.2f} s: "
                                    f"{outcome.error}")
            self.status(PlannerStatus("failed", plan_id=plan_id,
                                      planning_time_s=outcome.planning_time_s,
                                      last_error=outcome.error,
                                      failed_block=outcome.failed_block,
                                      metrics=outcome.metrics))
            return None
        plan = outcome.plan
        try:
            plan_msg = plan_to_msg(plan)
        except MessageError as err:
            self.get_logger().error(f"plan {plan_id} cannot be sent: {err}")
            self.status(PlannerStatus("failed", plan_id=plan_id, last_error=f"plan cannot be "
                                      f"sent: {err}"))
            return None
        self.plan_pub.publish(plan_msg)
        self.markers_pub.publish(plan_markers(plan, scene))
        self.get_logger().info(f"plan {plan_id}: {len(plan.actions)} actions in "
                               f"{outcome.planning_time_s:.2f} s (validated)")
        self.status(PlannerStatus("planned", plan_id=plan_id, n_actions=len(plan.actions),
                                  planning_time_s=outcome.planning_time_s,
                                  metrics=outcome.metrics))
        return None

    def _plan_in_child(self, *args: Any, should_stop: Callable[[], bool]) -> PlanOutcome:
        """``plan_goal(*args)`` in a process of its own (``child_process``)."""
        return self._child.run(plan_goal, *args, should_stop=should_stop)

    def status(self, status: PlannerStatus) -> None:
        self.status_pub.publish(planner_status_to_msg(status, self.get_clock().now().nanoseconds))


SPEC = NodeSpec(
    "planner",
    PlannerNode,
    "Plans pick-and-place and push actions (pIRS over a PRM; rearrangement pebble graphs "
    "for unlabeled and retrieval goals) from /blocks/detected to /goal_layout; publishes "
    "/plan, /plan/markers, /planner/status; serves /planner/replan and /plan_scene.",
    configs=PLANNER_PARAMETERS,
)


def main(args=None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
