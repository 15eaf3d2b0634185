"""``ros2 launch densepack cell.launch.py [profile:=real]``: densepack's nodes for an apt ROS
install, the same node set, parameter files, parameters and remappings as
``densepack-cell --profile <profile>`` (both read ``config/<profile's cell file>`` through
``nodes.cell.launch.load_cell``: one home for them).

``profile:=real`` (the default here) starts detector, planner, arm, gripper and executor on
the wall clock against ur_robot_driver, the Robotiq driver and a camera driver, which run
beside it (README, "On a real cell"); ``profile:=sim`` starts the simulated cell.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from nodes.cell.launch import PROFILES, load_cell
from nodes.common.paths import config_path


def _nodes(context, *args, **kwargs):
    profile = LaunchConfiguration("profile").perform(context)
    launches, missing = load_cell(config_path(PROFILES[profile]))
    if missing:
        raise RuntimeError(f"densepack nodes not installed: {missing}")
    return [Node(package="densepack", executable=launch.name, name=launch.name,
                 parameters=[*(str(p) for p in launch.params_files), launch.parameters],
                 remappings=list(launch.remaps.items()), output="screen",
                 respawn=launch.respawn.enabled, respawn_delay=launch.respawn.delay_s)
            for launch in launches]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        DeclareLaunchArgument("profile", default_value="real",
                              description=f"one of {sorted(PROFILES)}"),
        OpaqueFunction(function=_nodes),
    ])
