"""Helpers shared by tests that start separate processes."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def script(name: str) -> str:
    """Path of a console script installed in this venv (e.g. ``densepack-echo``)."""
    return str(BIN / name)


def tool(module: str) -> list[str]:
    """The command line of ``nodes.tools.<module>`` run as ``python -m`` (with ``cwd=REPO``:
    this checkout's code), for tools whose console script a stale install may not have yet."""
    return [sys.executable, "-m", f"nodes.tools.{module}"]


def spawn_python(code: str, **kwargs) -> subprocess.Popen:
    """Run a Python snippet in a separate process on this session's ROS domain."""
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code)],
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        **kwargs,
    )


PUBLISHER_SNIPPET = """
import time, rclpy
{imports}
from nodes.common.qos import {qos}
rclpy.init()
node = rclpy.create_node("test_publisher")
pub = node.create_publisher({msg_type}, "{topic}", {qos})
msg = {message}
for k in range({count}):
    pub.publish(msg)
    time.sleep({period})
time.sleep({linger})
node.destroy_node(); rclpy.shutdown()
"""


def spawn_publisher(topic: str, imports: str, msg_type: str, message: str, count: int = 200,
                    period: float = 0.1, qos: str = "RELIABLE",
                    linger: float = 0.0) -> subprocess.Popen:
    """Another process publishing ``message`` (a Python expression of type ``msg_type``, whose
    ``imports`` are given) on ``topic``."""
    return spawn_python(PUBLISHER_SNIPPET.format(
        topic=topic, imports=imports, msg_type=msg_type, message=message, count=count,
        period=period, qos=qos, linger=linger))


def read_mcap(bag: Path) -> list[tuple[str, str, int, object]]:
    """(topic, schema name, log time, decoded message) of every message, by the mcap reader."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (path,) = bag.glob("*.mcap")
    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [(channel.topic, schema.name, message.log_time, decoded)
                for schema, channel, message, decoded in reader.iter_decoded_messages()]
