"""densepack-echo prints what another process publishes (real DDS, separate processes)."""

from __future__ import annotations

import json
import subprocess

import pytest
import yaml

from tests.helpers import script, spawn_publisher

pytestmark = pytest.mark.ros


def run_echo(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run([script("densepack-echo"), *args], capture_output=True, text=True,
                          timeout=timeout)


STATUS = ("from densepack_interfaces.msg import ExecutorStatus",
          "ExecutorStatus", "ExecutorStatus(state=ExecutorStatus.STATE_RUNNING, plan_id='p1', "
          "action_index=3, action_total=5, block=4, detail='action 3/5')")


def test_echo_once_prints_a_typed_message_published_by_another_process():
    pub = spawn_publisher("/echo_test/status", *STATUS)
    try:
        out = run_echo("/echo_test/status", "--once", "--timeout", "30")
    finally:
        pub.kill()
        pub.wait()
    assert out.returncode == 0, out.stderr
    doc = yaml.safe_load(out.stdout.split("---")[0])
    assert doc["state"] == 2 and doc["plan_id"] == "p1" and doc["block"] == 4
    assert (doc["action_index"], doc["action_total"], doc["detail"]) == (3, 5, "action 3/5")
    assert doc["stamp"] == {"sec": 0, "nanosec": 0} and doc["metrics"] == []


def test_echo_json_count_prints_one_object_per_line():
    pub = spawn_publisher("/echo_test/plain", "from std_msgs.msg import String", "String",
                          "String(data='hello')", period=0.05)
    try:
        out = run_echo("/echo_test/plain", "--json", "--count", "3", "--timeout", "30")
    finally:
        pub.kill()
        pub.wait()
    assert out.returncode == 0, out.stderr
    lines = [json.loads(line) for line in out.stdout.splitlines()]
    assert lines == [{"data": "hello"}] * 3


def test_echo_gets_the_last_message_of_a_latched_topic():
    pub = spawn_publisher("/echo_test/latched", *STATUS, count=1, qos="LATCHED", linger=30)
    try:
        out = run_echo("/echo_test/latched", "--once", "--timeout", "30")
    finally:
        pub.kill()
        pub.wait()
    assert out.returncode == 0, out.stderr
    assert yaml.safe_load(out.stdout.split("---")[0])["detail"] == "action 3/5"


def test_echo_times_out_on_a_silent_topic_with_a_clear_message():
    out = run_echo("/echo_test/nobody_here", "--once", "--timeout", "1.5")
    assert out.returncode == 1
    assert "/echo_test/nobody_here not found" in out.stderr


def test_echo_refuses_a_malformed_type_name():
    out = run_echo("/x", "--type", "not_a_type", "--timeout", "1")
    assert out.returncode == 2 and "bad message type name" in out.stderr
