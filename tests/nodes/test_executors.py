"""PatientExecutor: a spin returns only once the workers have started the callbacks it handed
them (Jazzy's MultiThreadedExecutor returns at once; its spinning thread then loops on them,
holding the GIL the workers need to start them). A one-thread node process on the events
executor stops cleanly on a signal."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest
import rclpy
from densepack_interfaces.msg import ExecutorStatus
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

from nodes.common.executors import EXECUTOR_ENV, PatientExecutor, single_threaded
from nodes.common.qos import LATCHED
from tests.helpers import REPO

pytestmark = pytest.mark.ros

SPINS = 300


def spins_leaving_callbacks_unstarted(executor_type) -> int:
    """Of SPINS spins over four always-due timers, how many returned with a callback handed
    to a worker and not yet started."""
    context = Context()
    rclpy.init(context=context)
    executor = executor_type(num_threads=4, context=context)
    node = Node("handouts", context=context)
    for _ in range(4):
        node.create_timer(0.0005, lambda: sum(range(2000)), MutuallyExclusiveCallbackGroup())
    executor.add_node(node)
    try:
        unstarted = 0
        for _ in range(SPINS):
            executor.spin_once(timeout_sec=0.05)
            unstarted += any(not (task.executing() or task.done())
                             for task in list(executor._futures))
        return unstarted
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def test_a_spin_returns_once_the_workers_have_started_what_it_handed_them():
    stock = spins_leaving_callbacks_unstarted(MultiThreadedExecutor)
    patient = spins_leaving_callbacks_unstarted(PatientExecutor)
    assert patient < SPINS // 10 < stock, (patient, stock)


@pytest.mark.parametrize("choice", ["events", "single"])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_one_thread_node_process_stops_cleanly_on_a_signal(ros, choice, sig):
    """Regression: the events executor's own ``spin()`` ignores SIGTERM and SIGINT (the node
    lived on until killed); spun one callback at a time, the node stops and exits 0, so
    densepack-cell tells the stop from a crash."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "nodes.executor.node", "--ros-args", "--params-file",
         str(REPO / "config" / "executor.yaml")],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env=dict(os.environ, PYTHONUNBUFFERED="1", **{EXECUTOR_ENV: choice}))
    try:
        # spinning: its timer has published a status
        ros.wait_for_message("/executor/status", ExecutorStatus, timeout=60, qos=LATCHED)
        proc.send_signal(sig)
        code = proc.wait(timeout=20)
        assert code == 0, proc.stdout.read()
    finally:
        if proc.poll() is None:
            proc.kill()


def test_an_unknown_executor_choice_is_refused_by_name(monkeypatch):
    monkeypatch.setenv(EXECUTOR_ENV, "fast")
    with pytest.raises(ValueError, match=f"{EXECUTOR_ENV}='fast'"):
        single_threaded()


#: A node process whose timer callback meets the shut context (as a signal's shutdown arriving
#: mid-callback leaves it) or fails with the context still up: ``run_node``'s exit code.
CUT_SHORT = """
import sys
import rclpy
from rcl_interfaces.srv import ListParameters
from rclpy.node import Node
from nodes.common.runner import NodeSpec, run_node

def build():
    node = Node("cut_short")
    client = node.create_client(ListParameters, "/x")
    def tick():
        if sys.argv[1] == "shutdown":
            rclpy.try_shutdown()  # what the signal handler does, between two rcl calls
        client.service_is_ready()
        raise RuntimeError("the callback failed with the context up")
    node.create_timer(0.01, tick)
    return node

sys.exit(run_node(NodeSpec("cut_short", build, "test node", threads=1), []))
"""


@pytest.mark.parametrize(("case", "code"), [("shutdown", 0), ("bug", 1)])
def test_a_callback_cut_short_by_the_shutdown_is_a_clean_stop(case, code):
    """Regression (CI, 2026-12-04): a SIGINT arrived while the executor node's timer ran; its
    next rcl call raised on the shut context and the process exited 1 ("fatal"), which
    densepack-cell takes for a crash. A failure with the context still up stays fatal."""
    result = subprocess.run([sys.executable, "-c", CUT_SHORT, case], cwd=REPO, text=True,
                            capture_output=True, timeout=60)
    assert result.returncode == code, result.stderr
    assert ("stopped: a callback was cut short" if code == 0 else "fatal:") in result.stderr
