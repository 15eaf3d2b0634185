"""``densepack-view``: the cell, live, in the Foxglove app. A WebSocket server (foxglove-sdk,
``foxglove.sdk.v1``) that forwards the graph's topics as they are, CDR with their
``ros2msg`` schemas (so typed messages such as ``/executor/status`` open decoded, field by
field), and adds ``/view/scene``: the cell's 3-D scene as Foxglove ``SceneUpdate``s (detected
blocks as cubes, goal slots, the plan's arrows, the arm's TCP; ``nodes.tools.view_scene``).

Open the app, "Open connection", ``ws://localhost:8765``, then import
``config/foxglove/densepack-layout.json`` (``--write-layout`` regenerates it). Raw images are
left out unless ``--raw-images``: the compressed sibling is what the image panel shows.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import foxglove
import rclpy
from densepack_interfaces.msg import BlockPoseArray, ExecutorStatus, GoalLayout
from densepack_interfaces.msg import Plan as PlanMsg
from foxglove import Channel, Schema
from foxglove.channels import SceneUpdateChannel
from geometry_msgs.msg import PoseStamped
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions

from msgs_py import MessageError
from msgs_py.interface_codecs import block_set_from_msg, goal_layout_from_msg, plan_from_msg
from nodes.common.qos import LATCHED, RELIABLE
from nodes.common.runner import split_ros_args
from nodes.tools import bags
from nodes.tools.record import Recorder, stop_on_signals
from nodes.tools.view_layout import SCENE_TOPIC, STATUS_TOPIC, TCP_TOPIC, write_layout
from nodes.tools.view_scene import (
    block_entity,
    goal_entity,
    plan_entity,
    scene_update,
    tcp_entity,
)

#: How often the 3-D scene is sent (Hz, wall): the blocks move at the arm's pace.
SCENE_HZ = 5.0
DEFAULT_PORT = 8765


@dataclass(frozen=True, slots=True)
class ChannelConnection:
    """What ``Recorder`` keeps per topic (rosbags' ``Connection`` has these too)."""

    topic: str
    msgtype: str
    channel: Any


class FoxgloveSink:
    """A ``Recorder`` writer that logs each message to a Foxglove channel of its topic:
    CDR bytes untouched, the schema the full ``ros2msg`` definition of its type
    (``bags.message_definition``)."""

    def __init__(self, context: Any = None) -> None:
        self.context = context

    def add_connection(self, topic: str, msgtype: str, **_: Any) -> ChannelConnection:
        schema = Schema(name=msgtype, encoding="ros2msg",
                        data=bags.message_definition(msgtype).encode())
        return ChannelConnection(topic, msgtype, Channel(
            topic, schema=schema, message_encoding="cdr", context=self.context))

    def write(self, connection: ChannelConnection, stamp_ns: int, data: bytes) -> None:
        connection.channel.log(bytes(data), log_time=stamp_ns)


class SceneFeed:
    """Keeps the latest detection, goal, plan, executor progress and TCP from ``node``'s
    topics, and sends them as one ``SceneUpdate`` on ``/view/scene`` at ``SCENE_HZ``."""

    def __init__(self, node: Any, context: Any = None) -> None:
        self.node = node
        self.entities: dict[str, Any] = {}
        self.plan: Any = None
        self.done = 0
        self.goal: Any = None
        #: Every block id the detections have named (seen or missing): a labeled grid's
        #: slots are named after them.
        self.block_ids: frozenset[int] = frozenset()
        self.channel = SceneUpdateChannel(SCENE_TOPIC, context=context)
        node.create_subscription(BlockPoseArray, "/blocks/detected", self._on_blocks, RELIABLE)
        node.create_subscription(GoalLayout, "/goal_layout", self._on_goal, LATCHED)
        node.create_subscription(PlanMsg, "/plan", self._on_plan, LATCHED)
        node.create_subscription(ExecutorStatus, STATUS_TOPIC, self._on_status, LATCHED)
        node.create_subscription(PoseStamped, TCP_TOPIC, self._on_tcp, RELIABLE)
        node.create_timer(1.0 / SCENE_HZ, self.send)

    def _now(self) -> int:
        return self.node.get_clock().now().nanoseconds

    def _decode(self, decode: Any, msg: Any) -> Any:
        try:
            return decode(msg)
        except (MessageError, ValueError) as err:
            self.node.get_logger().warning(f"not drawn: {err}", throttle_duration_sec=5.0)
            return None

    def _on_blocks(self, msg: Any) -> None:
        blocks = self._decode(block_set_from_msg, msg)
        if blocks is None:
            return
        self.entities["blocks"] = block_entity(blocks, self._now())
        known = self.block_ids | {*blocks.ids, *blocks.missing}
        if known != self.block_ids:
            self.block_ids = known
            self._draw_goal()

    def _on_goal(self, msg: Any) -> None:
        layout = self._decode(goal_layout_from_msg, msg)
        if layout is not None:
            self.goal = layout
            self._draw_goal()

    def _draw_goal(self) -> None:
        if self.goal is not None:
            self.entities["goal"] = goal_entity(self.goal, self._now(), self.block_ids)

    def _on_plan(self, msg: Any) -> None:
        plan = self._decode(plan_from_msg, msg)
        if plan is not None:
            self.plan, self.done = plan, 0
            self._draw_plan()

    def _on_status(self, msg: Any) -> None:
        """Actions done so far leave the drawing: the arrows left are the work ahead."""
        if self.plan is not None and msg.plan_id == self.plan.plan_id:
            running = msg.state == ExecutorStatus.STATE_RUNNING
            done = max(0, int(msg.action_index) - (1 if running else 0))
            if done != self.done:
                self.done = done
                self._draw_plan()

    def _draw_plan(self) -> None:
        self.entities["plan"] = plan_entity(self.plan, self._now(), self.done)

    def _on_tcp(self, msg: Any) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        self.entities["tcp"] = tcp_entity((p.x, p.y, p.z), (q.x, q.y, q.z, q.w), self._now(),
                                          msg.header.frame_id)

    def send(self) -> None:
        if self.entities:
            self.channel.log(scene_update(self.entities.values()), log_time=self._now())


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="densepack-view", description=__doc__.splitlines()[0].split(": ", 1)[1])
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to listen on (0.0.0.0: reachable from other machines)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT,
                        help="WebSocket port (0: any free one, printed)")
    parser.add_argument("-x", "--exclude", nargs="*", default=[], metavar="TOPIC",
                        help="topics not to forward")
    parser.add_argument("--raw-images", action="store_true",
                        help="forward raw sensor_msgs/Image topics too (3.7 MB a frame)")
    parser.add_argument("--use-sim-time", action="store_true",
                        help="stamp messages with simulated time (/clock), as a replayed bag")
    parser.add_argument("--write-layout", type=Path, nargs="?", const=Path("-"), default=None,
                        metavar="PATH", help="write the Foxglove layout file and exit "
                        "(default: config/foxglove/densepack-layout.json)")
    return parser


def main(args: Sequence[str] | None = None) -> int:
    argv = list(sys.argv if args is None else ["densepack-view", *args])
    user_args, ros_argv = split_ros_args(argv)
    opts = build_parser().parse_args(user_args)
    if opts.write_layout is not None:
        where = write_layout(None if str(opts.write_layout) == "-" else opts.write_layout)
        print(f"densepack-view: wrote {where}", flush=True)
        return 0

    bags.typestore()  # fail early on a missing interface package
    stop = stop_on_signals()  # Ctrl-C / SIGTERM end the loop between spins
    rclpy.init(args=ros_argv, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("densepack_view", parameter_overrides=[
        Parameter("use_sim_time", Parameter.Type.BOOL, opts.use_sim_time)])
    server = foxglove.start_server(name="densepack", host=opts.host, port=opts.port)
    print(f"densepack-view: serving ws://{opts.host}:{server.port} (foxglove.sdk.v1); "
          "in the Foxglove app: Open connection, then import "
          "config/foxglove/densepack-layout.json; Ctrl-C stops", flush=True)
    forwarder = Recorder(node, FoxgloveSink(), all_topics=True,
                         exclude=[*opts.exclude, SCENE_TOPIC], raw_images=opts.raw_images,
                         log=lambda line: print(line, flush=True), tool="densepack-view",
                         verb="forwarding")
    SceneFeed(node)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    start = time.monotonic()
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        server.stop()
        node.destroy_node()
        rclpy.try_shutdown()
    print(f"densepack-view: stopped after {time.monotonic() - start:.0f} s; forwarded "
          f"{forwarder.summary()}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
