"""``densepack-cell --profile real``: densepack's nodes and not the sim, on the wall clock, every
remapping from a name the node really uses to a name the real driver really has; the ROS
launch file for apt installs reads the same profile."""

from __future__ import annotations

import ast
import importlib
import json
import subprocess
import sys

import pytest

from msgs_py import drivers
from nodes.cell.launch import NODE_MODULES, PROFILES, load_cell
from nodes.common.paths import config_path
from tests.helpers import REPO

#: What the drivers publish, subscribe and serve, as their launch files name them.
DRIVER_NAMES = {
    drivers.JOINT_STATES, drivers.TRAJECTORY_TOPIC, drivers.FORWARD_POSITION_TOPIC,
    drivers.TCP_POSE_TOPIC, drivers.SPEED_SCALING_TOPIC, drivers.SAFETY_MODE_TOPIC,
    drivers.ROBOT_MODE_TOPIC, drivers.PROGRAM_RUNNING_TOPIC, drivers.GRIPPER_JOINT_STATES,
    drivers.GRIPPER_COMMAND_TOPIC, drivers.GRIPPER_REACTIVATE,
    *(drivers.dashboard_service(c) for c in drivers.DASHBOARD_TRIGGERS),
    # a camera driver (and image_proc's rectified stream)
    "/camera/image_raw", "/camera/image_rect", "/camera/camera_info",
}


def real_launches():
    launches, missing = load_cell(config_path(PROFILES["real"]))
    assert not missing
    return launches


def test_the_real_profile_starts_densepacks_nodes_on_the_wall_clock():
    launches = real_launches()
    assert sorted(launch.name for launch in launches) == [
        "arm", "detector", "executor", "gripper", "planner"]
    for launch in launches:
        assert launch.parameters.get("use_sim_time") is False, launch.name
    out = subprocess.run([sys.executable, "-m", "nodes.tools.cell", "--profile", "real",
                          "--list", "--json"], capture_output=True, text=True, cwd=REPO,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    commands = json.loads(out.stdout)
    assert set(commands) == {launch.name for launch in launches}
    assert "-r" in commands["arm"] and f"{drivers.JOINT_STATES}:={drivers.JOINT_STATES}" in (
        commands["arm"])


def test_every_remapping_maps_a_name_the_node_uses_onto_a_drivers_name(ros):
    for launch in real_launches():
        if not launch.remaps:
            continue
        spec = importlib.import_module(launch.module).SPEC
        node = ros.add(spec.factory(context=ros.context))
        used = {e.topic_name for e in (*node.subscriptions, *node.publishers)}
        used |= {e.srv_name for e in (*node.services, *node.clients)}
        for source, target in launch.remaps.items():
            assert source in used, f"{launch.name} does not use {source}"
            assert target in DRIVER_NAMES, f"{launch.name}: {target} is no driver's name"


def test_the_launch_file_reads_the_same_profile_for_every_node():
    """There is no ROS launch package among the wheels: the launch file is read, not run. It
    takes its nodes, files, parameters and remappings from ``load_cell``, and every node
    it may start has an executable in the colcon package."""
    source = (REPO / "ros_ws/src/densepack/launch/cell.launch.py").read_text()
    tree = ast.parse(source)
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                for alias in node.names}
    assert {"load_cell", "PROFILES", "Node"} <= imported
    setup = (REPO / "ros_ws/src/densepack/setup.py").read_text()
    for launch in real_launches():
        assert f'"{launch.name}": "{NODE_MODULES[launch.name]}:main"' in setup


@pytest.mark.parametrize("profile", sorted(PROFILES))
def test_each_profile_file_exists(profile):
    assert config_path(PROFILES[profile]).is_file()
