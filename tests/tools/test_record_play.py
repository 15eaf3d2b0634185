"""densepack-record and densepack-play across processes, over real DDS.

The recorder records the sim node for a few seconds and is stopped as by Ctrl-C / SIGTERM;
the bag is read back with an independent reader (the ``mcap`` library with
``mcap-ros2-support``'s decoder, which knows only the schemas stored in the file). The player
replays a bag written here into an in-process subscriber: same bytes, same spacing over
``--rate``, the latched topic latched, ``/clock`` on the bag's time.
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from collections import Counter
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from densepack_interfaces.msg import BlockPose, BlockPoseArray, ExecutorStatus
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock

from msgs_py.ros import ns_to_stamp, stamp_to_ns
from nodes.common.qos import LATCHED, RELIABLE
from nodes.sim.node import SimNode
from nodes.tools import bags
from tests.helpers import REPO, read_mcap, spawn_publisher, tool

pytestmark = pytest.mark.ros


def start_recorder(bag: Path, *args: str) -> subprocess.Popen:
    return subprocess.Popen([*tool("record"), "-o", str(bag), *args], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def wait_for_line(proc: subprocess.Popen, text: str, timeout: float) -> list[str]:
    """Lines of ``proc`` up to the first holding ``text`` (read on a thread: no hang)."""
    lines: list[str] = []
    found = threading.Event()

    def read() -> None:
        for line in iter(proc.stdout.readline, ""):
            lines.append(line)
            if text in line:
                found.set()
                return

    threading.Thread(target=read, daemon=True).start()
    assert found.wait(timeout), f"'{text}' not printed in {timeout} s: {lines}"
    return lines


def stop(proc: subprocess.Popen, sig: int) -> str:
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out
    return out


def test_a_recording_of_the_sim_reads_back_with_the_mcap_reader(ros, tmp_path):
    sim = SimNode(context=ros.context, parameter_overrides=[
        Parameter("camera.rate_hz", value=2.0), Parameter("real_time_factor", value=1.0)])
    ros.add(sim)
    sim_now: list[int] = []
    ros.probe.create_subscription(Clock, "/clock", lambda m: sim_now.append(
        stamp_to_ns(m.clock)), RELIABLE)
    bag = tmp_path / "sim_bag"
    recorder = start_recorder(bag, "--all", "--use-sim-time")
    wait_for_line(recorder, "recording /camera/image_raw/compressed", timeout=60)
    # 4 s of simulated time (8 frames at 2 Hz), however slow the machine runs the sim
    deadline = time.monotonic() + 120
    while len(sim_now) < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    start = sim_now[-1]
    while sim_now[-1] < start + 4e9 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert sim_now[-1] >= start + 4e9, "the sim's clock did not run 4 s"
    stop(recorder, signal.SIGINT)

    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["storage_identifier"] == "mcap"
    counted = {t["topic_metadata"]["name"]: t["message_count"]
               for t in meta["topics_with_message_count"]}
    messages = read_mcap(bag)
    seen = Counter(topic for topic, *_ in messages)
    assert {k: v for k, v in counted.items() if v} == dict(seen)
    assert "/camera/image_raw" not in counted  # --all stores images compressed only
    for topic in ("/camera/image_raw/compressed", "/camera/camera_info", "/sim/ground_truth",
                  "/joint_states", "/tcp_pose_broadcaster/pose", "/clock", "/sim/events"):
        assert seen[topic] > 0, f"nothing recorded on {topic}: {dict(seen)}"
    assert seen["/camera/image_raw/compressed"] >= 4  # 2 Hz for 4+ s of sim time

    truth = [(t, m) for topic, _, t, m in messages if topic == "/sim/ground_truth"]
    schema = next(s for topic, s, *_ in messages if topic == "/sim/ground_truth")
    assert schema == "densepack_interfaces/msg/BlockPoseArray"
    log_time, last = truth[-1]
    assert sorted(b.id for b in last.blocks) == list(range(9))  # the default scene
    block0 = next(b for b in last.blocks if b.id == 0)
    assert abs(block0.pose.x - 0.52) < 0.01 and abs(block0.pose.y + 0.27) < 0.01
    # --use-sim-time: a message is stamped with the simulated time it arrived at
    assert 0 <= log_time - stamp_to_ns(last.header.stamp) < 0.5e9

    frames = [m for topic, _, _, m in messages if topic == "/camera/image_raw/compressed"]
    assert frames[0].format == "rgb8; jpeg compressed bgr8"
    pixels = cv2.imdecode(np.frombuffer(bytes(frames[0].data), np.uint8), cv2.IMREAD_COLOR)
    assert pixels.shape == (960, 1280, 3) and 20 < pixels.mean() < 235


def test_sigterm_closes_a_valid_bag_with_the_latched_message_recorded_niced(tmp_path):
    status = ("from densepack_interfaces.msg import ExecutorStatus", "ExecutorStatus",
              "ExecutorStatus(state=ExecutorStatus.STATE_DONE, detail='all placed')")
    pub = spawn_publisher("/record_test/status", *status, count=1, qos="LATCHED", linger=60)
    bag = tmp_path / "latched"
    recorder = start_recorder(bag, "/record_test/status", "--nice", "5")
    try:
        wait_for_line(recorder, "recording /record_test/status", timeout=60)
        # beside a cell it yields the CPU to the cell's nodes
        assert os.getpriority(os.PRIO_PROCESS, recorder.pid) == os.getpriority(
            os.PRIO_PROCESS, 0) + 5
        time.sleep(1.0)
        out = stop(recorder, signal.SIGTERM)
    finally:
        pub.kill()
        pub.wait()
    assert "1 messages on 1 topics" in out
    ((topic, schema, _, msg),) = read_mcap(bag)
    assert (topic, schema) == ("/record_test/status", "densepack_interfaces/msg/ExecutorStatus")
    assert msg.detail == "all placed" and msg.state == ExecutorStatus.STATE_DONE
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    (info,) = meta["topics_with_message_count"]
    assert info["topic_metadata"]["offered_qos_profiles"][0]["durability"] == "transient_local"


BAG0 = 1_000_000_000_000  # the bag's first stamp (ns): simulated time 1000 s
STEP = 200_000_000  # ground truth every 0.2 s (bag time)
N_TRUTH = 15


def truth_message(k: int) -> BlockPoseArray:
    msg = BlockPoseArray(block_size=0.0508, blocks=[BlockPose(id=k)])
    msg.header.stamp = ns_to_stamp(BAG0 + k * STEP)
    msg.header.frame_id = "world"
    return msg


def write_bag(path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        status = writer.add_connection(
            "/play_test/status", "densepack_interfaces/msg/ExecutorStatus",
            typestore=bags.typestore(), offered_qos_profiles=[bags.to_bag_qos(LATCHED)])
        truth = writer.add_connection(
            "/play_test/truth", "densepack_interfaces/msg/BlockPoseArray",
            typestore=bags.typestore(), offered_qos_profiles=[bags.to_bag_qos(RELIABLE)])
        writer.write(status, BAG0, serialize_message(ExecutorStatus(
            state=ExecutorStatus.STATE_RUNNING, detail="recorded")))
        for k in range(N_TRUTH):
            writer.write(truth, BAG0 + k * STEP, serialize_message(truth_message(k)))


def test_play_republishes_a_bag_at_its_rate_with_the_bag_clock(ros, tmp_path):
    bag = tmp_path / "play_bag"
    write_bag(bag)
    got: list[tuple[float, int, BlockPoseArray]] = []  # (received at, bag clock then, message)
    clocks: list[int] = []
    ros.probe.create_subscription(Clock, "/clock", lambda m: clocks.append(
        stamp_to_ns(m.clock)), RELIABLE)
    ros.probe.create_subscription(BlockPoseArray, "/play_test/truth", lambda m: got.append(
        (time.monotonic(), clocks[-1] if clocks else 0, m)), RELIABLE)
    player = subprocess.Popen([*tool("play"), str(bag), "--rate", "2", "--delay", "0.5",
                               "--wait-for-subscribers", "/play_test/truth", "/clock"],
                              cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True)
    try:
        deadline = time.monotonic() + 60
        while not got and time.monotonic() < deadline:
            time.sleep(0.02)
        # Subscribed after the latched status went out: it is replayed to this late joiner.
        late = ros.wait_for_message("/play_test/status", ExecutorStatus, timeout=20, qos=LATCHED)
        out, _ = player.communicate(timeout=60)
    finally:
        if player.poll() is None:
            player.kill()
            player.wait()
    assert player.returncode == 0, out
    assert f"published {N_TRUTH + 1} messages" in out
    assert late.detail == "recorded"
    assert [m for *_, m in got] == [truth_message(k) for k in range(N_TRUTH)]
    # Paced on the bag's clock: each message comes after /clock reached about its stamp (the
    # clock goes out just before it; the two topics may arrive one message apart), not all at
    # once ahead of the clock ...
    for k, (_, clock_then, _) in enumerate(got[1:], start=1):
        assert clock_then >= BAG0 + (k - 1) * STEP, (k, clock_then)
    last = BAG0 + (N_TRUTH - 1) * STEP
    assert got[0][1] < last
    # ... and never faster than --rate 2 (a loaded machine only plays it slower)
    span = got[-1][0] - got[0][0]
    assert span >= 0.9 * (N_TRUTH - 1) * STEP * 1e-9 / 2, span
    assert clocks and clocks == sorted(clocks)
    assert BAG0 <= clocks[0] < BAG0 + STEP and last <= clocks[-1] < last + STEP
