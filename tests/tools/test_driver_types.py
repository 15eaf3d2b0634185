"""The types densepack speaks on the drivers' topics are the real drivers' types.

A ROS 2 Jazzy type is identified on the wire by its name and its type hash (RIHS01): a copy
with another definition, or another package name, is another type. The expected hashes below
were computed with Jazzy's own rosidl generators from the published definitions: ur_robot_driver
3.8.0's ``ur_dashboard_msgs`` (densepack builds two of its messages into the pip venv, since no
wheel holds them) and the Jazzy releases of ``common_interfaces`` and ``rcl_interfaces`` (what an
apt install of the drivers uses; the PyPI wheels must match them). The test reads each hash
from a live publisher's endpoint information, as a driver on the same domain would see it.
"""

from __future__ import annotations

import importlib
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: type -> the RIHS01 hash of its published Jazzy definition.
DRIVER_TYPES = {
    "ur_dashboard_msgs/msg/SafetyMode":
        "RIHS01_9eb2716e6905f06e4eb60af26712660486e909026aa89c553dd633f1fb22f592",
    "ur_dashboard_msgs/msg/RobotMode":
        "RIHS01_ba3c379b3c995f660b38d03a195dc23ed7571a1bc06ceed2cec38c75ae9bd634",
    "sensor_msgs/msg/JointState":
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e",
    "geometry_msgs/msg/PoseStamped":
        "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
    "std_msgs/msg/Float64":
        "RIHS01_705ba9c3d1a09df43737eb67095534de36fd426c0587779bda2bc51fe790182a",
    "std_msgs/msg/Float64MultiArray":
        "RIHS01_1025ddc6b9552d191f89ef1a8d2f60f3d373e28b283d8891ddcc974e8c55397f",
    "std_msgs/msg/Bool":
        "RIHS01_feb91e995ff9ebd09c0cb3d2aed18b11077585839fb5db80193b62d74528f6c9",
    "trajectory_msgs/msg/JointTrajectory":
        "RIHS01_179b33eba59d676f6d967ac71fe35e7ca2f64b2f3928f4a018cec115e213796e",
    "sensor_msgs/msg/Image":
        "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47",
    "sensor_msgs/msg/CameraInfo":
        "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275",
    "sensor_msgs/msg/CompressedImage":
        "RIHS01_15640771531571185e2efc8a100baf923961a4d15d5569652e6cb6691e8e371a",
}


def _message_class(name: str):
    package, kind, cls = name.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), cls)


@pytest.mark.ros
def test_every_driver_facing_type_has_the_real_packages_hash(ros):
    node = ros.probe
    for k, name in enumerate(DRIVER_TYPES):
        node.create_publisher(_message_class(name), f"/type_hash_probe_{k}", 1)
    for k, (name, expected) in enumerate(DRIVER_TYPES.items()):
        info = node.get_publishers_info_by_topic(f"/type_hash_probe_{k}")
        assert len(info) == 1 and info[0].topic_type == name
        assert str(info[0].topic_type_hash) == expected, name


def test_the_venv_copy_of_ur_dashboard_msgs_is_the_published_definition():
    """Byte for byte what ur_robot_driver 3.8.0 ships (constants included, which the hash
    leaves out), and never built by colcon."""
    msg_dir = ROOT / "driver_msgs" / "ur_dashboard_msgs" / "msg"
    safety = (msg_dir / "SafetyMode.msg").read_text()
    assert safety.splitlines()[2] == "uint8 PROTECTIVE_STOP=3"
    assert safety.endswith("\nuint8 mode\n") and safety.count("=") == 13
    robot = (msg_dir / "RobotMode.msg").read_text()
    assert robot.startswith("int8 NO_CONTROLLER=-1\n") and robot.endswith("\nint8 mode\n")
    assert (ROOT / "driver_msgs" / "COLCON_IGNORE").exists()
    assert not (ROOT / "ros_ws" / "src" / "ur_dashboard_msgs").exists()


def test_both_interface_packages_build_with_the_same_pinned_toolchain():
    ours = tomllib.loads((ROOT / "ros_ws/src/densepack_interfaces/pyproject.toml").read_text())
    copy = tomllib.loads((ROOT / "driver_msgs/ur_dashboard_msgs/pyproject.toml").read_text())
    assert ours["build-system"] == copy["build-system"]
