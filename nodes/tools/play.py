"""``densepack-play``: our ``ros2 bag play``. Republishes a rosbag2 bag (MCAP or SQLite, read
by ``rosbags``) on the graph, each topic with its recorded type and a QoS made from the one
its publishers offered (latched topics latched: a late subscriber gets the last message).

Messages go out at their recorded times (``--rate`` faster or slower) and ``/clock`` carries
the bag's time, so nodes with ``use_sim_time`` (the executor in the cell) live on the
recorded clock; a ``/clock`` recorded in the bag is replaced by it (``--clock-hz 0``: no
``/clock`` of ours, the recorded one, if any, is played like any topic).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import rclpy
from builtin_interfaces.msg import Time
from rclpy.duration import Duration
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosbags.rosbag2 import Reader
from rosbags.rosbag2.errors import ReaderError
from rosgraph_msgs.msg import Clock

from nodes.common.messages import import_message_type
from nodes.common.runner import split_ros_args
from nodes.tools import bags

CLOCK_TOPIC = "/clock"


class Player:
    """Publishes the messages of an open rosbags ``reader`` on ``node``: one publisher per
    recorded topic (``topics`` to choose some), ``/clock`` at ``clock_hz`` (wall)."""

    def __init__(self, node: Any, reader: Any, topics: Sequence[str] = (), rate: float = 1.0,
                 clock_hz: float = 50.0) -> None:
        if rate <= 0:
            raise ValueError(f"--rate must be positive, not {rate}")
        self.reader = reader
        self.rate = rate
        self.clock_period = 1.0 / clock_hz if clock_hz > 0 else None
        wanted = {t if t.startswith("/") else "/" + t for t in topics}
        self.connections = [
            c for c in reader.connections
            if (not wanted or c.topic in wanted)
            and not (self.clock_period and c.topic == CLOCK_TOPIC)]
        self.publishers: dict[int, Any] = {}
        by_topic: dict[str, Any] = {}
        for c in self.connections:  # one publisher a topic, even if it was recorded in parts
            if c.topic not in by_topic:
                by_topic[c.topic] = node.create_publisher(
                    import_message_type(c.msgtype), c.topic,
                    bags.replay_qos(list(c.ext.offered_qos_profiles)))
            self.publishers[c.id] = by_topic[c.topic]
        self.clock_msg = Clock
        self.clock_pub = (node.create_publisher(Clock, CLOCK_TOPIC, QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE)) if self.clock_period else None)
        self.published = 0
        self.clock_ns = -1  # the last /clock published: never goes back

    def bag_time(self, wall: float, wall0: float, bag0: int) -> int:
        return bag0 + round((wall - wall0) * self.rate * 1e9)

    def _publish_clock(self, stamp_ns: int) -> None:
        if self.clock_pub is not None and stamp_ns > self.clock_ns:
            self.clock_ns = stamp_ns
            self.clock_pub.publish(self.clock_msg(clock=Time(sec=stamp_ns // 10**9,
                                                             nanosec=stamp_ns % 10**9)))

    def wait_for_subscribers(self, topics: Sequence[str], timeout_s: float) -> list[str]:
        """Wait until each of ``topics`` has a subscriber matched (discovery can take seconds
        on a loaded machine: a fixed delay loses the first messages); the topics still
        without one after ``timeout_s``."""
        wanted = {t if t.startswith("/") else "/" + t for t in topics}
        publishers = {c.topic: self.publishers[c.id] for c in self.connections
                      if c.topic in wanted}
        missing = sorted(wanted - set(publishers))
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            waiting = [t for t, p in publishers.items() if p.get_subscription_count() == 0]
            if not waiting:
                return missing
            time.sleep(0.05)
        return missing + [t for t, p in publishers.items() if p.get_subscription_count() == 0]

    def play(self, delay_s: float = 0.0) -> int:
        """Publish every chosen message at its time; returns how many were published."""
        bag0 = self.reader.start_time
        wall0 = time.monotonic() + delay_s
        next_clock = wall0
        for connection, stamp, data in self.reader.messages(connections=self.connections):
            due = wall0 + (stamp - bag0) / (self.rate * 1e9)
            while True:
                now = time.monotonic()
                if self.clock_period is not None and now >= next_clock and now >= wall0:
                    self._publish_clock(self.bag_time(now, wall0, bag0))
                    next_clock += self.clock_period * max(1, int((now - next_clock)
                                                                 / self.clock_period) + 1)
                if now >= due:
                    break
                wake = due if self.clock_period is None else min(due, next_clock)
                time.sleep(max(0.0, wake - now))
            self._publish_clock(stamp)  # the clock never lags behind a message's time
            self.publishers[connection.id].publish(bytes(data))
            self.published += 1
        self.flush()
        return self.published

    def flush(self, timeout_s: float = 2.0) -> None:
        """Wait until reliable subscribers acknowledged what was sent: a player that exits
        right after its last message would take that message with it."""

        for publisher in {id(p): p for p in self.publishers.values()}.values():
            publisher.wait_for_all_acked(Duration(seconds=timeout_s))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="densepack-play", description=__doc__.splitlines()[0].split(": ", 1)[1])
    parser.add_argument("bag", type=Path, help="rosbag2 folder (densepack-record's output)")
    parser.add_argument("--topics", nargs="*", default=[], metavar="TOPIC",
                        help="play only these topics")
    parser.add_argument("-r", "--rate", type=float, default=1.0,
                        help="playback speed: 2 plays twice as fast as recorded")
    parser.add_argument("--clock-hz", type=float, default=50.0,
                        help="/clock messages per wall second, with the bag's time (0: none)")
    parser.add_argument("--delay", type=float, default=1.0,
                        help="wait this long (s) before the first message, for subscribers "
                        "to discover the publishers")
    parser.add_argument("--wait-for-subscribers", nargs="*", default=[], metavar="TOPIC",
                        help="before that delay, wait (up to 60 s) until each of these topics "
                        "has a subscriber")
    return parser


def describe(reader: Any) -> str:
    topics = {c.topic for c in reader.connections}
    return (f"{reader.message_count} messages on {len(topics)} topics, "
            f"{reader.duration * 1e-9:.1f} s")


def main(args: Sequence[str] | None = None) -> int:
    argv = list(sys.argv if args is None else ["densepack-play", *args])
    user_args, ros_argv = split_ros_args(argv)
    opts = build_parser().parse_args(user_args)
    # Python's own handlers: Ctrl-C and SIGTERM stop the loop (there is no executor to wake).
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    rclpy.init(args=ros_argv, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("densepack_play")
    start = time.monotonic()
    player = None
    try:
        with Reader(opts.bag) as reader:
            player = Player(node, reader, opts.topics, opts.rate, opts.clock_hz)
            print(f"densepack-play: {opts.bag}: {describe(reader)}; rate {opts.rate:g}",
                  flush=True)
            unmatched = player.wait_for_subscribers(opts.wait_for_subscribers, 60.0)
            if unmatched:
                print(f"densepack-play: no subscriber on {', '.join(unmatched)}; playing anyway",
                      file=sys.stderr, flush=True)
            player.play(opts.delay)
    except KeyboardInterrupt:
        pass
    except (ReaderError, ValueError) as err:
        print(f"densepack-play: {err}", file=sys.stderr, flush=True)
        return 2
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    done = player.published if player is not None else 0
    print(f"densepack-play: published {done} messages in {time.monotonic() - start:.1f} s",
          flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
