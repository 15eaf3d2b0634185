"""Transport: camera frames between processes, with Fast DDS's default shared-memory segment
and with the one the sim asks for (``nodes.common.transports``).

Per variant, one writer process publishes 1280x960 rgb8 frames (the sim's size, the camera's
QoS) at ``--rate`` Hz to ``--readers`` reader processes, which run at nice 19 (as a busy
cell's readers wait for a core); ``--load`` processes spin at normal priority beside them.
Figures: frames each reader got, delay from the frame's stamp to its callback (median, max),
frames later than 1 s, and the fragments' buffers the writer had to take back from readers
that had not yet read them (Fast DDS's count, "overflows_count", logged when its segment
closes; the writer process raises Fast DDS's log to warnings for it).
"""

from __future__ import annotations

import argparse
import ctypes
import os
import re
import statistics
import subprocess
import sys
import time
from typing import Any

import rclpy
from rclpy.time import Time
from sensor_msgs.msg import Image

from nodes.common.qos import CAMERA
from nodes.common.transports import FRAME_WRITER_TRANSPORTS, TRANSPORTS_ENV

#: (name, FASTDDS_BUILTIN_TRANSPORTS or None for Fast DDS's own default)
VARIANTS = (("default (512 kB segment)", None), ("sized (the sim's)", FRAME_WRITER_TRANSPORTS))
TOPIC = "/bench/transport/image"
LATE_S = 1.0
COLUMNS = ["transports", "frames", "received", "delay_median_s", "delay_max_s", "late",
           "buffers_taken_back"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--frames", type=int, default=40, help="frames per variant")
    parser.add_argument("--rate", type=float, default=2.0, help="frames per second")
    parser.add_argument("--readers", type=int, default=2, help="reader processes")
    parser.add_argument("--load", type=int, default=0,
                        help="processes spinning at normal priority beside the readers")


def run(opts: argparse.Namespace) -> list[dict[str, Any]]:
    frames = 6 if opts.quick else opts.frames
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    return [_variant(name, transports, frames, opts, domain) for name, transports in VARIANTS]


def _variant(name: str, transports: str | None, frames: int, opts: argparse.Namespace,
             domain: str) -> dict[str, Any]:
    env = {k: v for k, v in os.environ.items() if k != TRANSPORTS_ENV}
    env["ROS_DOMAIN_ID"] = domain
    if transports:
        env[TRANSPORTS_ENV] = transports
    window = frames / opts.rate + 12.0
    me = [sys.executable, "-m", "nodes.bench.transport"]
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
            for _ in range(opts.load)]
    try:
        readers = [subprocess.Popen(["nice", "-n", "19", *me, "reader", str(window)], env=env,
                                    stdout=subprocess.PIPE, text=True)
                   for _ in range(opts.readers)]
        time.sleep(2.0)
        writer = subprocess.run([*me, "writer", str(frames), str(opts.rate), str(opts.readers)],
                                env=env, capture_output=True, text=True, timeout=window + 30)
        delays = [float(d) for r in readers for d in r.communicate(timeout=window + 30)[0].split()]
    finally:
        for hog in hogs:
            hog.kill()
    # Fast DDS's log goes to stdout
    log = writer.stdout + writer.stderr
    taken_back = sum(int(n) for n in re.findall(r"overflows_count (\d+)", log))
    return {"transports": name, "frames": frames,
            "received": f"{len(delays)}/{frames * opts.readers}",
            "delay_median_s": statistics.median(delays) if delays else float("nan"),
            "delay_max_s": max(delays, default=float("nan")),
            "late": sum(d > LATE_S for d in delays), "buffers_taken_back": taken_back}


def _writer(frames: int, rate: float, readers: int) -> None:
    rclpy.init()
    warning = 1  # eprosima::fastdds::dds::Log::Kind::Warning: the segment's overflow count
    fastdds = ctypes.CDLL("libfastrtps.so.2.14")
    fastdds._ZN8eprosima7fastdds3dds3Log12SetVerbosityENS2_4KindE(ctypes.c_int(warning))
    node = rclpy.create_node("transport_bench_writer")
    pub = node.create_publisher(Image, TOPIC, CAMERA)
    deadline = time.monotonic() + 10.0
    while pub.get_subscription_count() < readers and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)
    msg = Image(height=960, width=1280, encoding="rgb8", step=3840, data=bytes(960 * 3840))
    for _ in range(frames):
        msg.header.stamp = node.get_clock().now().to_msg()
        pub.publish(msg)
        time.sleep(1.0 / rate)
    time.sleep(5.0)  # the last frames' repairs
    node.destroy_node()
    rclpy.shutdown()


def _reader(window_s: float) -> None:
    rclpy.init()
    node = rclpy.create_node("transport_bench_reader")
    delays: list[float] = []

    def on_image(msg: Image) -> None:
        delays.append((node.get_clock().now() - Time.from_msg(msg.header.stamp)).nanoseconds
                      * 1e-9)

    node.create_subscription(Image, TOPIC, on_image, CAMERA)
    end = time.monotonic() + window_s
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.1)
    print(" ".join(f"{d:.4f}" for d in delays), flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    role, *params = sys.argv[1:]
    if role == "writer":
        _writer(int(params[0]), float(params[1]), int(params[2]))
    else:
        _reader(float(params[0]))
