"""ament_python package exposing densepack's nodes to ``ros2 run densepack <node>``.

The Python packages, ``config/`` and ``sim_assets/`` are symlinks to the checkout's top
level, so the colcon package and the pip distribution are one code base. Only nodes whose
module exists in the checkout get an executable.
"""

from pathlib import Path

from setuptools import find_packages, setup

HERE = Path(__file__).resolve().parent
PACKAGE = "densepack"

EXECUTABLES = {
    "sim": "nodes.sim.node:main",
    "detector": "nodes.detector.node:main",
    "planner": "nodes.planner.node:main",
    "executor": "nodes.executor.node:main",
    "arm": "nodes.arm.node:main",
    "gripper": "nodes.gripper.node:main",
    "goal": "nodes.goal.node:main",
    "calibrate": "nodes.calibration.cli:main",
    "plan": "nodes.planner.cli:main",
    "echo": "nodes.tools.echo:main",
    "cell": "nodes.tools.cell:main",
    "bench": "nodes.tools.bench:main",
}


def _exists(target: str) -> bool:
    module = target.split(":")[0]
    return (HERE / (module.replace(".", "/") + ".py")).exists()


def _data_files() -> list[tuple[str, list[str]]]:
    files = [
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
        ("share/" + PACKAGE + "/launch", sorted(str(p.relative_to(HERE))
                                               for p in (HERE / "launch").glob("*.py"))),
    ]
    for top in ("config", "sim_assets"):
        for path in sorted((HERE / top).rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                rel = path.relative_to(HERE)
                files.append((f"share/{PACKAGE}/{rel.parent}", [str(rel)]))
    return files


setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(include=["nodes", "nodes.*", "msgs_py", "msgs_py.*"]),
    data_files=_data_files(),
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="densepack maintainers",
    maintainer_email="maintainers@densepack.invalid",
    description="Dense block packing with a simulated UR10e (ROS 2 Jazzy nodes)",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            f"{name} = {target}" for name, target in EXECUTABLES.items() if _exists(target)
        ]
    },
)
