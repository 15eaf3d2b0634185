"""The arm and gripper nodes against two drivers: the sim node, and a kinematic stand-in written
from the drivers' documentation (``standin.py``, no PyBullet). The same tests, the same
assertions: the nodes rely on nothing that only the sim does.

* the arm node tracks a Cartesian path within 1 mm (the tool pose the driver reports, from
  the measured joints);
* the gripper node closes on a block and reports it held (a stall short of the command, from
  the knuckle joint alone);
* a protective stop is unlocked and the program restarted on the arm node's request, after
  which the arm follows setpoints again.
"""

from __future__ import annotations

import math
import subprocess
import threading
import time

import numpy as np
import pytest
from densepack_interfaces.msg import ArmStatus, BlockPoseArray, GripperStatus
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from msgs_py import drivers
from msgs_py import ros as msg_codecs
from msgs_py.cell import BLOCK_SIZE
from nodes.arm.node import ArmNode
from nodes.common.qos import LATCHED
from nodes.common.standard_msgs import pose_stamped_msg, stamp_seconds
from nodes.common.transforms import tool_down_quaternion
from nodes.executor.player import MAX_TICKS_PER_STEP
from nodes.gripper.node import GripperNode
from nodes.sim.config import HOME_JOINTS, PARK_POSITION
from tests.helpers import script

from .standin import DriverStandIn

pytestmark = pytest.mark.ros
BACKENDS = [pytest.param("standin", id="standin"),
            pytest.param("sim", id="sim", marks=pytest.mark.slow)]


class Cell:
    """The driver (sim or stand-in), the arm and gripper nodes, and a setpoint stream."""

    def __init__(self, ros, backend: str, driver_log) -> None:
        self.ros, self.backend = ros, backend
        sim_time = [Parameter("use_sim_time", value=True)]
        self.driver: subprocess.Popen | None = None
        if backend == "sim":  # a process of its own, as a driver runs: its physics never
            # waits on this process's threads (sharing one, the path ran 3-43 mm off in CI)
            self.driver = subprocess.Popen(
                [script("densepack-sim"), "--ros-args", "-p", "real_time_factor:=1.0",
                 "-p", "camera.rate_hz:=0.0", "-p", "protective_stop_unlock_after_s:=0.5"],
                stdout=driver_log, stderr=subprocess.STDOUT, text=True)
        else:
            self.standin = ros.add(DriverStandIn(HOME_JOINTS, object_width=BLOCK_SIZE,
                                                 context=ros.context))
        ros.add(ArmNode(context=ros.context, parameter_overrides=sim_time))
        ros.add(GripperNode(context=ros.context, parameter_overrides=sim_time))
        self.now = 0.0
        self.tcp: list[tuple[float, np.ndarray]] = []
        self._lock = threading.Lock()
        ros.probe.create_subscription(Clock, "/clock", self._on_clock, 10)
        ros.probe.create_subscription(PoseStamped, "/arm/tcp_pose", self._on_tcp, 10)
        self.setpoints = ros.publisher("/arm/cartesian_setpoint", PoseStamped)
        self.gripper = ros.publisher("/gripper/command", Float64)
        try:
            self.wait_status("ready", timeout=60)
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Stop the sim's process."""
        if self.driver is None:
            return
        self.driver.terminate()
        try:
            self.driver.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.driver.kill()
            self.driver.wait()

    def _on_clock(self, msg: Clock) -> None:
        self.now = stamp_seconds(msg.clock)

    def _on_tcp(self, msg: PoseStamped) -> None:
        p = msg.pose.position
        with self._lock:
            self.tcp.append((self.now, np.array([p.x, p.y, p.z])))

    def latest_tcp(self) -> np.ndarray:
        deadline = time.monotonic() + 10
        while not self.tcp and time.monotonic() < deadline:
            time.sleep(0.02)
        with self._lock:
            return self.tcp[-1][1]

    def wait_status(self, state: str, timeout: float = 30.0):
        code = getattr(ArmStatus, f"STATE_{state.upper()}")
        return self.ros.wait_for_message("/arm/status", ArmStatus, lambda m: m.state == code,
                                         timeout=timeout, qos=LATCHED)

    def stream(self, path, seconds: float, rate: float = 50.0, yaw: float = 0.0) -> None:
        """Stream ``path(u)`` for u in [0, 1] over ``seconds`` of the cell's clock, stamped
        with it, as the executor streams: the path's time advances at most
        ``MAX_TICKS_PER_STEP`` ticks per setpoint, so a streamer held up (this test's thread
        shares the process with the sim and the nodes) resumes where it was instead of
        sending a chord across the path."""
        self.ros.wait_for_subscribers(self.setpoints)
        s, last = 0.0, None
        while True:
            t = self.now
            if last is not None and t - last < 1.0 / rate:
                time.sleep(0.002)
                continue
            if last is not None:
                s += min(t - last, MAX_TICKS_PER_STEP / rate)
            last = t
            u = min(s / seconds, 1.0)
            stamp = Clock().clock
            stamp.sec, stamp.nanosec = int(t), round((t % 1.0) * 1e9) % 1_000_000_000
            self.setpoints.publish(pose_stamped_msg(stamp, path(u), tool_down_quaternion(yaw)))
            if u >= 1.0:
                return

    def go_to(self, target, seconds: float = 2.0, yaw: float = 0.0, tol: float = 1e-3) -> None:
        start = self.latest_tcp().copy()
        target = np.asarray(target, dtype=float)
        self.stream(lambda u: start + _smooth(u) * (target - start), seconds, yaw=yaw)
        self.wait_tcp(target, tol)

    def wait_tcp(self, target, tol: float = 1e-3, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if np.linalg.norm(self.latest_tcp() - target) <= tol:
                return
            time.sleep(0.05)
        raise AssertionError(f"TCP {self.latest_tcp()} did not reach {target}")

    def grip(self, gap: float) -> GripperStatus:
        """Command a gap and wait until the fingers are there or stopped on something."""
        self.ros.wait_for_subscribers(self.gripper)
        self.gripper.publish(Float64(data=gap))

        def settled(msg: GripperStatus) -> bool:
            status = msg_codecs.gripper_status_from_msg(msg)
            return (abs(status.requested_gap - gap) < 1e-6 and status.object != "moving")
        return msg_codecs.gripper_status_from_msg(self.ros.wait_for_message(
            "/gripper/status", GripperStatus, settled, timeout=30))

    def protective_stop(self) -> None:
        """The robot's safety system stops the arm: the sim by pressing on a block, the
        stand-in by its test hook."""
        if self.backend == "standin":
            assert self.ros.call_service("/standin/protective_stop", Trigger).success
            return
        block = msg_codecs.block_set_from_msg(self.ros.wait_for_message(
            "/sim/ground_truth", BlockPoseArray)).blocks[0]
        self.grip(0.0)
        self.go_to([block.x, block.y, 0.15])
        start = np.array([block.x, block.y, 0.15])
        self.stream(lambda u: start + u * np.array([0.0, 0.0, -0.13]), 1.0)


def _smooth(u: float) -> float:
    return 0.5 - 0.5 * math.cos(math.pi * u)


@pytest.fixture(params=BACKENDS)
def cell(request, ros, tmp_path):
    with open(tmp_path / "driver.log", "w+") as log:
        cell = Cell(ros, request.param, log)
        try:
            yield cell
        finally:
            cell.close()
            log.seek(0)
            print(log.read()[-4000:])  # the sim's log: pytest shows it when a test failed


def test_the_arm_node_tracks_a_cartesian_path_within_1_mm(cell):
    start, end = np.array(PARK_POSITION), np.array([0.75, 0.10, 0.20])
    cell.go_to(start, tol=1e-4)  # at rest on the path's start
    cell.tcp.clear()
    t0 = cell.now
    cell.stream(lambda u: start + _smooth(u) * (end - start), 2.0)
    cell.wait_tcp(end)
    path = [p for t, p in cell.tcp if t >= t0]
    assert len(path) > 50
    direction = (end - start) / np.linalg.norm(end - start)
    offs = [float(np.linalg.norm((p - start) - np.dot(p - start, direction) * direction))
            for p in path]
    worst = int(np.argmax(offs))
    assert offs[worst] <= 1e-3, (
        f"{cell.backend}: {offs[worst] * 1e3:.2f} mm off the straight path at sample {worst} "
        f"of {len(path)} ({np.round(path[worst], 4)}): "
        f"{[round(o * 1e3, 2) for o in offs[max(0, worst - 5):worst + 5]]}")


def test_the_gripper_node_closes_on_a_block_and_reports_it(cell):
    if cell.backend == "sim":  # bring the open fingers down around block 0
        block = msg_codecs.block_set_from_msg(cell.ros.wait_for_message(
            "/sim/ground_truth", BlockPoseArray)).blocks[0]
        cell.grip(BLOCK_SIZE + 0.02)
        cell.go_to([block.x, block.y, 0.15], yaw=block.theta)
        cell.go_to([block.x, block.y, 0.012], yaw=block.theta)
    opened = cell.grip(BLOCK_SIZE + 0.02)
    assert opened.object == "at_position"
    held = cell.grip(0.0)
    assert held.holds_object, held
    assert abs(held.gap - BLOCK_SIZE) < 0.002


def test_a_protective_stop_is_unlocked_and_the_program_restarted(cell):
    cell.protective_stop()
    stopped = cell.wait_status("protective_stop")
    assert not stopped.program_running
    answers = []
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        answers.append(cell.ros.call_service("/arm/unlock_protective_stop", Trigger))
        try:
            ready = cell.wait_status("ready", timeout=2.0)
            break
        except TimeoutError:
            continue
    else:
        raise AssertionError(f"not unlocked: {[a.message for a in answers]}")
    assert ready.program_running and ready.safety_mode == drivers.SAFETY_NORMAL
    assert answers[0].success and "unlocking" in answers[0].message
    up = cell.latest_tcp() + np.array([0.0, 0.0, 0.05])
    cell.go_to(up)  # it follows setpoints again
