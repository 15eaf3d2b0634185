"""``densepack-echo TOPIC``: our ``ros2 topic echo``.

Finds the topic's type on the ROS graph, imports the message class (the cell's own
``densepack_interfaces`` types as any other), matches the publishers' QoS (so latched topics
replay their last message and best-effort camera streams are heard) and prints each message
as YAML (``--json``: one JSON object per line).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence
from typing import Any

import rclpy
import yaml
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from nodes.common.messages import canonical_type_name, import_message_type, message_to_dict
from nodes.common.runner import split_ros_args


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="densepack-echo", description="Print the messages published on a ROS 2 topic."
    )
    parser.add_argument("topic", help="topic name, e.g. /executor/status")
    parser.add_argument("--once", action="store_true", help="print one message and exit")
    parser.add_argument("--count", type=int, default=0, help="exit after N messages")
    parser.add_argument("--json", action="store_true", help="one JSON object per line")
    parser.add_argument(
        "--timeout", type=float, default=None, help="give up after S seconds without a message"
    )
    parser.add_argument("--type", dest="msg_type", help="message type if the topic is not up yet")
    parser.add_argument("--full", action="store_true", help="print long arrays in full")
    return parser


def format_message(msg: Any, as_json: bool, full: bool) -> str:
    data = message_to_dict(msg, None if full else 32)
    if as_json:
        return json.dumps(data, allow_nan=True)
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=False).rstrip() + "\n---"


def subscription_qos(node: Any, topic: str) -> Any:
    """Match the publishers: transient-local if they all latch, best-effort if any is."""

    infos = node.get_publishers_info_by_topic(topic)
    latched = bool(infos) and all(
        i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos
    )
    best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
    return QoSProfile(
        depth=10,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def find_topic_type(node: Any, topic: str, deadline: float | None) -> str | None:
    while deadline is None or time.monotonic() < deadline:
        for name, types in node.get_topic_names_and_types():
            if name == topic and types:
                return types[0]
        rclpy.spin_once(node, timeout_sec=0.1)
    return None


def main(args: Sequence[str] | None = None) -> int:
    argv = list(sys.argv if args is None else ["densepack-echo", *args])
    user_args, ros_argv = split_ros_args(argv)
    opts = build_parser().parse_args(user_args)
    topic = opts.topic if opts.topic.startswith("/") else "/" + opts.topic
    limit = 1 if opts.once else max(opts.count, 0)
    deadline = None if opts.timeout is None else time.monotonic() + opts.timeout

    rclpy.init(args=ros_argv)
    node = rclpy.create_node(f"densepack_echo_{os.getpid()}")
    received = 0
    try:
        type_name = opts.msg_type or find_topic_type(node, topic, deadline)
        if type_name is None:
            print(f"densepack-echo: topic {topic} not found within {opts.timeout} s",
                  file=sys.stderr)
            return 1
        type_name = canonical_type_name(type_name)
        msg_class = import_message_type(type_name)
        time.sleep(0.2)  # let discovery report every publisher before choosing QoS
        rclpy.spin_once(node, timeout_sec=0.05)

        def on_message(msg: Any) -> None:
            nonlocal received
            if limit and received >= limit:
                return
            received += 1
            print(format_message(msg, opts.json, opts.full), flush=True)

        node.create_subscription(msg_class, topic, on_message, subscription_qos(node, topic))
        while not limit or received < limit:
            if deadline is not None and time.monotonic() > deadline:
                if received == 0:
                    print(f"densepack-echo: no message on {topic} within {opts.timeout} s",
                          file=sys.stderr)
                    return 1
                break
            rclpy.spin_once(node, timeout_sec=0.1)
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    except ValueError as err:
        print(f"densepack-echo: {err}", file=sys.stderr)
        return 2
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
