"""densepack-view across processes: a WebSocket client speaking ``foxglove.sdk.v1`` (the
Foxglove app's protocol, here the ``websockets`` package) connects to the live view, sees the
camera's channel advertised with its ``ros2msg`` schema, subscribes, and receives the very
CompressedImage an in-process publisher sent, in CDR; the view's own 3-D scene comes too.
"""

from __future__ import annotations

import json
import re
import signal
import struct
import subprocess
import threading
import time

import pytest
from densepack_interfaces.msg import BlockPose, BlockPoseArray
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import CompressedImage

from nodes.common.qos import CAMERA, RELIABLE
from tests.helpers import REPO, tool

pytestmark = pytest.mark.ros
SUBPROTOCOL = "foxglove.sdk.v1"  # foxglove-sdk 0.30's name for the ws-protocol
MESSAGE_DATA = 0x01  # server -> client binary opcode


def start_view() -> tuple[subprocess.Popen, int, list[str], threading.Thread]:
    """The view on a free port; one thread reads its output to the end (the port line, then
    everything for the failure message), so nothing else may read it."""
    proc = subprocess.Popen([*tool("view"), "--port", "0"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    port: list[int] = []
    lines: list[str] = []
    ready = threading.Event()

    def read() -> None:
        for line in iter(proc.stdout.readline, ""):
            lines.append(line)
            found = re.search(r"serving ws://[\d.]+:(\d+)", line)
            if found:
                port.append(int(found.group(1)))
                ready.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    if not ready.wait(60):
        proc.kill()
        raise AssertionError("densepack-view did not start serving in 60 s")
    return proc, port[0], lines, reader


def frame(index: int) -> CompressedImage:
    msg = CompressedImage(format="rgb8; jpeg compressed bgr8",
                          data=bytes([0xFF, 0xD8, index % 256]) + bytes(range(200)))
    msg.header.frame_id = "camera_optical_frame"
    msg.header.stamp.sec = 100 + index
    return msg


def test_a_websocket_client_gets_the_camera_and_the_scene(ros):
    from websockets.sync.client import connect

    camera = ros.probe.create_publisher(CompressedImage, "/camera/image_raw/compressed", CAMERA)
    detected = ros.probe.create_publisher(BlockPoseArray, "/blocks/detected", RELIABLE)
    blocks = BlockPoseArray(block_size=0.0508, blocks=[BlockPose(id=4)])
    blocks.header.frame_id = "world"
    view, port, lines, reader = start_view()
    sent: list[CompressedImage] = []
    stop = threading.Event()

    def publish() -> None:
        k = 0
        while not stop.is_set():
            sent.append(frame(k))
            camera.publish(sent[-1])
            detected.publish(blocks)
            k += 1
            time.sleep(0.1)

    pump = threading.Thread(target=publish, daemon=True)
    pump.start()
    try:
        with connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL],
                     open_timeout=20) as ws:
            assert ws.subprotocol == SUBPROTOCOL
            channels: dict[str, dict] = {}
            subscribed: dict[int, str] = {}
            got: dict[str, bytes] = {}
            deadline = time.monotonic() + 30
            while len(got) < 2 and time.monotonic() < deadline:
                try:
                    data = ws.recv(timeout=1.0)
                except TimeoutError:
                    continue
                if isinstance(data, str):
                    op = json.loads(data)
                    if op["op"] == "advertise":
                        for ch in op["channels"]:
                            channels[ch["topic"]] = ch
                    for sub_id, topic in enumerate(
                            ("/camera/image_raw/compressed", "/view/scene"), start=1):
                        if topic in channels and sub_id not in subscribed:
                            subscribed[sub_id] = topic
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                                {"id": sub_id, "channelId": channels[topic]["id"]}]}))
                elif data[0] == MESSAGE_DATA:
                    sub_id, _log_time = struct.unpack_from("<IQ", data, 1)
                    got.setdefault(subscribed[sub_id], data[13:])
    finally:
        stop.set()
        pump.join(timeout=2)
        view.send_signal(signal.SIGINT)
        view.wait(timeout=30)
        reader.join(timeout=10)
        view.stdout.close()
    assert view.returncode == 0, "".join(lines)
    cam = channels["/camera/image_raw/compressed"]
    assert (cam["encoding"], cam["schemaName"], cam["schemaEncoding"]) == (
        "cdr", "sensor_msgs/msg/CompressedImage", "ros2msg")
    assert "std_msgs/Header header" in cam["schema"] and "MSG: std_msgs/Header" in cam["schema"]
    assert "/camera/image_raw/compressed" in got, f"no camera message; advertised {list(channels)}"
    image = deserialize_message(got["/camera/image_raw/compressed"], CompressedImage)
    assert image in sent  # the very message, bytes and header
    assert channels["/view/scene"]["schemaName"] == "foxglove.SceneUpdate"
    assert b"blocks" in got["/view/scene"] and b"world" in got["/view/scene"]
