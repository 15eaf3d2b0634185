"""How the arm node's commands suit rclpy's timing: joint trajectory snippets vs streamed joint
positions, through the sim's stand-in of ur_robot_driver, over DDS, each node its own process.

``densepack-bench arm [--quick] [--interfaces trajectory forward_position] [--seeds K]``
starts ``densepack-sim`` (with the matching ``motion_controller``) and ``densepack-arm`` (with
``command_interface``) on a private ROS_DOMAIN_ID, streams Cartesian setpoints at 50 Hz on the
sim's clock as the executor does (a straight line across the workspace and a circle, cosine
speed profiles up to 0.6 m/s), and records the tool pose the arm node computes from the
measured joints. Per row: the worst and median distance of the measured TCP from the commanded
path (mm), the error at the end after the arm settles (mm), how long after the last setpoint's
stamp the TCP came within 1 mm of the end (s, simulated), and the commands the sim refused.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import threading
import time
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Clock

from nodes.common.harness import RosHarness, allocate_domain_id
from nodes.common.standard_msgs import pose_stamped_msg, stamp_seconds
from nodes.common.transforms import tool_down_quaternion

COLUMNS = ["interface", "path", "runs", "off_path_mm_max", "off_path_mm_median",
           "end_error_mm_max", "settle_s_median", "refused"]
PATHS = ("line", "circle")
RATE_HZ = 50.0
START = np.array([0.55, -0.25, 0.20])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--interfaces", nargs="+", default=["trajectory", "forward_position"],
                        choices=["trajectory", "forward_position"])
    parser.add_argument("--paths", nargs="+", default=list(PATHS), choices=PATHS)


def path_point(path: str, u: float) -> np.ndarray:
    """The commanded TCP at fraction ``u`` (0-1, cosine profile) of ``path``."""
    s = 0.5 - 0.5 * math.cos(math.pi * min(max(u, 0.0), 1.0))
    if path == "line":
        return START + s * np.array([0.30, 0.45, -0.10])
    angle = 2.0 * math.pi * s
    return START + 0.15 * np.array([math.sin(angle), 1.0 - math.cos(angle), 0.0])


def off_path(path: str, p: np.ndarray) -> float:
    """Distance (m) of ``p`` from the commanded path."""
    samples = np.array([path_point(path, u) for u in np.linspace(0.0, 1.0, 2001)])
    return float(np.min(np.linalg.norm(samples - p, axis=1)))


class Rig:
    """The sim and the arm node as processes; this process streams and listens."""

    def __init__(self, interface: str, seed: int) -> None:
        self.domain = allocate_domain_id(120, 200)
        env = dict(os.environ, ROS_DOMAIN_ID=str(self.domain),
                   ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")
        controller = ("scaled_joint_trajectory_controller" if interface == "trajectory"
                      else "forward_position_controller")
        self.procs = [
            subprocess.Popen([sys.executable, "-m", "nodes.sim.node", "--ros-args", "-p",
                              f"motion_controller:={controller}", "-p", "camera.rate_hz:=0.0",
                              "-p", f"seed:={seed}"], env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True),
            subprocess.Popen([sys.executable, "-m", "nodes.arm.node", "--ros-args", "-p",
                              "use_sim_time:=true", "-p", f"command_interface:={interface}"],
                             env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL),
        ]
        self.ros = RosHarness(domain_id=self.domain)
        self.now = 0.0
        self.tcp: list[tuple[float, np.ndarray]] = []
        self.lock = threading.Lock()
        self.ros.probe.create_subscription(Clock, "/clock", self._on_clock, 10)
        self.ros.probe.create_subscription(PoseStamped, "/arm/tcp_pose", self._on_tcp, 10)
        self.pub = self.ros.publisher("/arm/cartesian_setpoint", PoseStamped)
        self.ros.wait_for_subscribers(self.pub, timeout=60.0)

    def _on_clock(self, msg: Any) -> None:
        self.now = stamp_seconds(msg.clock)

    def _on_tcp(self, msg: Any) -> None:
        p = msg.pose.position
        with self.lock:
            self.tcp.append((self.now, np.array([p.x, p.y, p.z])))

    def stream(self, point, seconds: float) -> float:
        """Stream ``point(u)``, u from 0 to 1 over ``seconds`` of the sim's clock, at 50 Hz
        stamped with it; returns the last stamp (s)."""
        t0, last = self.now, None
        while True:
            t = self.now
            if last is not None and t - last < 1.0 / RATE_HZ:
                time.sleep(0.002)
                continue
            last = t
            u = min((t - t0) / seconds, 1.0)
            stamp = Time(sec=int(t), nanosec=round((t % 1.0) * 1e9) % 1_000_000_000)
            self.pub.publish(pose_stamped_msg(stamp, point(u), tool_down_quaternion(0.0)))
            if u >= 1.0:
                return t

    def go_to(self, target: np.ndarray) -> None:
        """A straight line from where the tool is to ``target``, then settle on it."""
        deadline = time.monotonic() + 30.0
        while not self.tcp and time.monotonic() < deadline:
            time.sleep(0.05)
        here = self.tcp[-1][1].copy()
        self.stream(lambda u: here + (0.5 - 0.5 * math.cos(math.pi * u)) * (target - here), 2.0)
        self.settle(target, 1e-4)

    def settle(self, target: np.ndarray, tol: float, timeout_wall: float = 30.0) -> float:
        """Simulated time at which the TCP came within ``tol`` of ``target``."""
        deadline = time.monotonic() + timeout_wall
        while time.monotonic() < deadline:
            with self.lock:
                if self.tcp and np.linalg.norm(self.tcp[-1][1] - target) <= tol:
                    return self.tcp[-1][0]
            time.sleep(0.01)
        return math.nan

    def close(self) -> int:
        """Stop everything; the commands the sim refused (its error log lines)."""
        self.ros.shutdown()
        for proc in self.procs:
            proc.terminate()
        try:
            log = self.procs[0].communicate(timeout=30)[0] or ""
        except subprocess.TimeoutExpired:  # a loaded machine: do not wait for a clean exit
            self.procs[0].kill()
            log = self.procs[0].communicate()[0] or ""
        try:
            self.procs[1].wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.procs[1].kill()
            self.procs[1].wait()
        return sum("[ERROR]" in line for line in log.splitlines())


def run_one(interface: str, path: str, seed: int) -> dict[str, Any]:
    rig = Rig(interface, seed)
    refused = 0
    try:
        rig.go_to(path_point(path, 0.0))
        with rig.lock:
            rig.tcp.clear()
        t_start = rig.now
        t_end = rig.stream(lambda u: path_point(path, u), 3.0)
        settled = rig.settle(path_point(path, 1.0), 1e-3)
        time.sleep(0.5)
        with rig.lock:
            during = [p for t, p in rig.tcp if t >= t_start]
            final = rig.tcp[-1][1]
    finally:
        refused = rig.close()
    offs = [off_path(path, p) for p in during[::2]]
    return {"off_max": max(offs), "off_median": statistics.median(offs),
            "end_error": float(np.linalg.norm(final - path_point(path, 1.0))),
            "settle_s": settled - t_end, "refused": refused}


def run(opts: argparse.Namespace) -> list[dict[str, Any]]:
    seeds = opts.seeds or (1 if opts.quick else 3)
    rows = []
    for interface in opts.interfaces:
        for path in opts.paths:
            runs = [run_one(interface, path, seed) for seed in range(seeds)]
            rows.append({
                "interface": interface, "path": path, "runs": len(runs),
                "off_path_mm_max": 1e3 * max(r["off_max"] for r in runs),
                "off_path_mm_median": 1e3 * statistics.median(r["off_median"] for r in runs),
                "end_error_mm_max": 1e3 * max(r["end_error"] for r in runs),
                "settle_s_median": statistics.median(r["settle_s"] for r in runs),
                "refused": sum(r["refused"] for r in runs), "per_run": runs,
            })
    return rows
