"""``densepack-record``: our ``ros2 bag record``. Records topics of the graph into a rosbag2
folder (``metadata.yaml`` + MCAP storage, written by ``rosbags``).

Topics are named, or ``--all`` (every topic but hidden ones, and raw ``sensor_msgs/Image``
streams unless ``--raw-images``: their ``.../compressed`` sibling is recorded instead). A
topic is subscribed to as soon as it appears on the graph, with the QoS its publishers offer
(latched topics give their last message), and its messages are stored as they came, in CDR,
without decoding; each is stamped with its time of receipt (the ROS clock, simulated time
with ``--use-sim-time``). Ctrl-C, SIGTERM or ``--duration`` end the recording; the bag is
closed (its summary and ``metadata.yaml`` written) on the way out.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import signal
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

from nodes.common.executors import single_threaded
from nodes.common.messages import canonical_type_name, import_message_type
from nodes.common.runner import die_with_launcher, split_ros_args
from nodes.common.transports import use_profile
from nodes.tools import bags

#: How often the graph is looked at for new topics (s, wall time).
DISCOVERY_PERIOD_S = 0.5
RAW_IMAGE_TYPE = "sensor_msgs/msg/Image"


class Recorder:
    """Subscribes ``node`` to the wanted topics as they appear and writes every message into
    the open rosbags ``writer`` (everything runs on the node's executor thread). Any object
    with rosbags' ``add_connection`` / ``write`` will do: ``densepack-view`` passes one that
    forwards to Foxglove channels; ``tool`` and ``verb`` word the log lines."""

    def __init__(self, node: Any, writer: Any, topics: Sequence[str] = (), all_topics: bool = False,
                 exclude: Sequence[str] = (), raw_images: bool = False,
                 log: Any = print, tool: str = "densepack-record",
                 verb: str = "recording") -> None:
        self.node = node
        self.writer = writer
        self.topics = {t if t.startswith("/") else "/" + t for t in topics}
        self.all_topics = all_topics
        self.exclude = set(exclude)
        self.raw_images = raw_images
        self.log = log
        self.tool = tool
        self.verb = verb
        self.connections: dict[str, Any] = {}
        self.counts: dict[str, int] = {}
        self._pending: list[tuple[Any, bytes]] = []  # came before the first /clock
        self._subscriptions: list[Any] = []
        self._skipped: set[str] = set()
        node.create_timer(DISCOVERY_PERIOD_S, self.discover)

    def wanted(self, topic: str, type_name: str) -> bool:
        if topic in self.topics:
            return True
        if not self.all_topics or topic in self.exclude or bags.is_hidden(topic):
            return False
        return self.raw_images or type_name != RAW_IMAGE_TYPE

    def discover(self) -> None:
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self.connections or topic in self._skipped or not types:
                continue
            type_name = canonical_type_name(types[0])
            if not self.wanted(topic, type_name):
                continue
            offered = bags.publisher_qos(self.node.get_publishers_info_by_topic(topic))
            if not offered:
                continue  # subscribers only so far: its QoS is known once a publisher comes
            try:
                self._subscribe(topic, type_name, offered)
            except (ValueError, KeyError) as err:  # a type neither rclpy nor the typestore knows
                self._skipped.add(topic)
                self.log(f"{self.tool}: not {self.verb} {topic}: {err}")

    def _subscribe(self, topic: str, type_name: str, offered: list[Any]) -> None:
        msg_class = import_message_type(type_name)
        connection = self.writer.add_connection(
            topic, type_name, typestore=bags.typestore(),
            offered_qos_profiles=[bags.to_bag_qos(q) for q in offered])
        self.connections[topic] = connection
        self.counts[topic] = 0

        def on_message(data: bytes, connection: Any = connection) -> None:
            self._write(connection, data)

        self._subscriptions.append(self.node.create_subscription(
            msg_class, topic, on_message, bags.subscription_qos(offered), raw=True))
        self.log(f"{self.tool}: {self.verb} {topic} ({type_name})")

    def _write(self, connection: Any, data: bytes) -> None:
        stamp = self.node.get_clock().now().nanoseconds
        if stamp == 0:  # simulated time before the first /clock: stamped when it comes
            self._pending.append((connection, data))
            return
        for early, early_data in self._pending:
            self._store(early, stamp, early_data)
        self._pending.clear()
        self._store(connection, stamp, data)

    def _store(self, connection: Any, stamp: int, data: bytes) -> None:
        self.writer.write(connection, stamp, data)
        self.counts[connection.topic] += 1

    def summary(self) -> str:
        total = sum(self.counts.values())
        return f"{total} messages on {len(self.counts)} topics"


def stop_on_signals() -> threading.Event:
    """An event SIGINT and SIGTERM set (instead of raising or shutting rclpy down), so a
    tool's loop ends between two spins and closes its files."""
    stop = threading.Event()

    def handler(signum: int, frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
    return stop


def default_output() -> Path:
    return Path(dt.datetime.now().strftime("rosbag2_%Y_%m_%d-%H_%M_%S"))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="densepack-record", description=__doc__.splitlines()[0].split(": ", 1)[1])
    parser.add_argument("topics", nargs="*", help="topics to record, e.g. /executor/status")
    parser.add_argument("-a", "--all", action="store_true",
                        help="every topic but hidden ones and raw images")
    parser.add_argument("-o", "--output", type=Path, default=None,
                        help="bag folder to create (rosbag2_<date>-<time>)")
    parser.add_argument("-x", "--exclude", nargs="*", default=[], metavar="TOPIC",
                        help="topics --all leaves out")
    parser.add_argument("--raw-images", action="store_true",
                        help="with --all, record raw sensor_msgs/Image topics too (3.7 MB a frame)")
    parser.add_argument("--use-sim-time", action="store_true",
                        help="stamp messages with simulated time (/clock), not the system clock")
    parser.add_argument("--duration", type=float, default=None,
                        help="stop after this many seconds (wall time)")
    parser.add_argument("--no-compression", action="store_true",
                        help="store MCAP chunks uncompressed (default: zstd)")
    parser.add_argument("--quiet", action="store_true", help="print the summary line only")
    parser.add_argument("--nice", type=int, default=0, metavar="N",
                        help="lower this process's CPU priority by N, as nice(1) does (a "
                        "recorder beside a cell on a small computer)")
    return parser


def open_writer(path: Path, compress: bool) -> Any:
    writer = Writer(path, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP)
    if compress:  # zstd per MCAP chunk: state streams shrink ~5x, JPEG frames stay as they are
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    writer.open()
    return writer


def main(args: Sequence[str] | None = None) -> int:
    argv = list(sys.argv if args is None else ["densepack-record", *args])
    user_args, ros_argv = split_ros_args(argv)
    parser = build_parser()
    opts = parser.parse_args(user_args)
    if not opts.topics and not opts.all:
        parser.error("name the topics to record, or --all")
    output = opts.output or default_output()
    if output.exists():
        print(f"densepack-record: {output} exists; give another --output", file=sys.stderr)
        return 2
    bags.typestore()  # fail early on a missing interface package
    if opts.nice:
        os.nice(opts.nice)
    die_with_launcher()
    # Ctrl-C and SIGTERM only raise a flag the loop checks between spins: rclpy's own handlers
    # shut the context down under a spin in progress, which then dies of an RCLError.
    stop = stop_on_signals()
    use_profile(os.environ)  # as the nodes': their transports, heartbeat and announcements
    rclpy.init(args=ros_argv, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(
        "densepack_record", parameter_overrides=[
            Parameter("use_sim_time", Parameter.Type.BOOL, opts.use_sim_time)])
    writer = open_writer(output, not opts.no_compression)

    def log(line: str) -> None:
        if not opts.quiet:
            print(line, flush=True)

    recorder = Recorder(node, writer, opts.topics, opts.all, opts.exclude, opts.raw_images, log)
    # the nodes' one-thread executor (rclpy's events executor): it takes a message for a
    # fraction of what the wait-set executor costs; beside the default run, the recorder's
    # CPU 6.3 -> 2.6 s and the run's wall time 24.2-25.6 -> 21.0-22.1 s (two cores)
    executor = single_threaded()
    executor.add_node(node)
    print(f"densepack-record: recording to {output} "
          f"({'all topics' if opts.all else ', '.join(sorted(recorder.topics))}); Ctrl-C stops",
          flush=True)
    start = time.monotonic()
    try:
        while not stop.is_set() and (opts.duration is None
                                     or time.monotonic() - start < opts.duration):
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        writer.close()
        node.destroy_node()
        rclpy.try_shutdown()
    size = sum(f.stat().st_size for f in output.iterdir())
    print(f"densepack-record: wrote {output}: {recorder.summary()}, {size / 1e6:.1f} MB, "
          f"{time.monotonic() - start:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
