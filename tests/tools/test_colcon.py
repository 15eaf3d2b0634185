"""The ament_python package in ros_ws/ builds with colcon and installs runnable executables."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.helpers import BIN, REPO


@pytest.fixture(scope="module")
def colcon_install(tmp_path_factory) -> Path:
    work = tmp_path_factory.mktemp("colcon") / "ros_ws"
    shutil.copytree(REPO / "ros_ws" / "src", work / "src", symlinks=False,
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    env = dict(os.environ, PATH=f"{BIN}:{os.environ['PATH']}")
    # Only the python package: densepack_interfaces (ament_cmake) needs ament_cmake and the
    # rosidl generators, which an apt ROS install has and this venv does not (pip builds it in
    # an isolated environment from its own pyproject.toml, and the venv has it). Ignored, not
    # just unselected: densepack depends on it, and colcon would look for its install.
    out = subprocess.run([str(BIN / "colcon"), "build", "--packages-ignore",
                          "densepack_interfaces"],
                         cwd=work, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    return work / "install" / "densepack"


def installed_env(install: Path) -> dict[str, str]:
    site = next((install / "lib").glob("python3*/site-packages"))
    return dict(os.environ, PYTHONPATH=str(site), AMENT_PREFIX_PATH=str(install),
                DENSEPACK_SHARE="")


def expected_executables() -> list[str]:
    """Every node whose module is in the checkout, as setup.py promises."""
    names = {"goal": "nodes/goal/node.py", "echo": "nodes/tools/echo.py",
             "cell": "nodes/tools/cell.py", "sim": "nodes/sim/node.py",
             "detector": "nodes/detector/node.py", "planner": "nodes/planner/node.py",
             "executor": "nodes/executor/node.py", "arm": "nodes/arm/node.py",
             "gripper": "nodes/gripper/node.py"}
    return [name for name, path in names.items() if (REPO / path).exists()]


def test_colcon_installs_every_node_under_lib_densepack(colcon_install):
    lib = colcon_install / "lib" / "densepack"
    for name in expected_executables():
        assert (lib / name).is_file(), f"{name} missing from {sorted(os.listdir(lib))}"
    share = colcon_install / "share" / "densepack"
    assert (share / "config" / "cell.yaml").is_file()
    assert (share / "config" / "real" / "cell.yaml").is_file()
    assert (share / "launch" / "cell.launch.py").is_file()
    assert (share / "package.xml").is_file()


def test_installed_executables_answer_help_from_the_install_tree(colcon_install):
    env = installed_env(colcon_install)
    for name in expected_executables():
        out = subprocess.run([str(colcon_install / "lib" / "densepack" / name), "--help"],
                             env=env, capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, f"{name}: {out.stderr}"
        assert "usage:" in out.stdout
    where = subprocess.run(
        [str(BIN / "python"), "-c",
         "import nodes; from nodes.common.paths import share_dir; "
         "print(nodes.__file__); print(share_dir())"],
        env=env, capture_output=True, text=True, timeout=60, cwd=colcon_install)
    module_file, share = where.stdout.split()
    assert module_file.startswith(str(colcon_install)), "the checkout shadowed the install"
    assert share.startswith(str(colcon_install)), "data not found in share/densepack"


def test_the_node_package_depends_on_the_interface_package():
    import xml.etree.ElementTree as ET

    root = ET.parse(REPO / "ros_ws" / "src" / "densepack" / "package.xml").getroot()
    assert "densepack_interfaces" in [e.text for e in root.findall("depend")]
    interfaces = ET.parse(REPO / "ros_ws" / "src" / "densepack_interfaces" / "package.xml")
    assert interfaces.getroot().find("export/build_type").text == "ament_cmake"
