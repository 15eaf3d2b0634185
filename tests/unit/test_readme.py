"""The README is the front door; the node reference (docs/nodes.md) lists every declared
parameter with its declared default."""

from __future__ import annotations

import importlib
import re

import pytest

from nodes.common.params import describe_config
from tests.helpers import REPO

README = (REPO / "README.md").read_text()
NODES = (REPO / "docs" / "nodes.md").read_text()
NODE_MODULES = ["nodes.sim.node", "nodes.detector.node", "nodes.planner.node",
                "nodes.executor.node", "nodes.arm.node", "nodes.gripper.node",
                "nodes.goal.node"]


def section(name: str) -> str:
    match = re.search(rf"^### {name} \(.*?(?=^### |^## )", NODES, re.S | re.M)
    assert match, f"docs/nodes.md has no '### {name} (...)' section"
    return match.group(0)


@pytest.mark.parametrize("module", NODE_MODULES)
def test_every_parameter_is_in_the_readme_section_of_its_node(module):
    spec = importlib.import_module(module).SPEC
    text = section(spec.name)
    missing = [row["name"] for prefix, cls in spec.configs for row in describe_config(cls, prefix)
               if f"`{row['name']}`" not in text and f"`{row['name'].split('.')[-1]}`" not in text]
    assert not missing, f"README section '{spec.name}' lacks parameters {missing}"


def test_the_two_commands_are_at_the_top():
    head = README[:2500]
    assert "<!-- main-command -->" in head and "<!-- test-command -->" in head
    assert "densepack-run" in head


@pytest.mark.parametrize("module", NODE_MODULES)
def test_the_defaults_in_the_readme_tables_are_the_declared_ones(module):
    import yaml

    spec = importlib.import_module(module).SPEC
    text = section(spec.name)
    wrong = []
    for prefix, cls in spec.configs:
        for row in describe_config(cls, prefix):
            short = row["name"].split(".")[-1]
            shown = re.search(rf"^\| `(?:{re.escape(row['name'])}|{re.escape(short)})` \| \w+ \| "
                              r"`([^`]*)` \|", text, re.M)
            if shown and yaml.safe_load(shown.group(1)) != yaml.safe_load(row["default"]):
                wrong.append(f"{row['name']}: README {shown.group(1)}, declared {row['default']}")
    assert not wrong, f"README section '{spec.name}' shows stale defaults: {wrong}"


def test_the_documented_rearrange_goal_is_the_default_scenes_goal():
    """The `ros2 action send_goal` example of docs/nodes.md fills a Rearrange goal that
    decodes to the default scene's goal layout and passes the executor's goal checks."""
    import yaml
    from densepack_interfaces.action import Rearrange

    from msgs_py import BlockSet, load_scene
    from msgs_py.ros import rearrange_goal_from_msg
    from nodes.common.paths import config_path
    from nodes.executor.config import ExecutorConfig
    from nodes.executor.goals import check_layout
    from nodes.goal.node import goal_layout

    example = re.search(r'send_goal --feedback /rearrange densepack_interfaces/action/Rearrange '
                        r'"(\{layout:.*?\})"\n', NODES, re.S)
    assert example, "docs/nodes.md lost its send_goal example"

    def fill(msg, data):
        for name, value in data.items():
            if isinstance(value, dict):
                fill(getattr(msg, name), value)
            else:
                setattr(msg, name, value)
        return msg

    goal = fill(Rearrange.Goal(), yaml.safe_load(example.group(1)))
    scene = load_scene(config_path("scenes/default.yaml"))
    layout = rearrange_goal_from_msg(goal)
    assert layout == goal_layout(scene)
    check_layout(layout, BlockSet(scene.blocks), ExecutorConfig().safe_box)


def test_the_documented_state_table_is_the_executors():
    from nodes.executor.states import transitions_markdown

    shown = re.search(r"<!-- transitions -->\n(.*?)\n<!-- /transitions -->", NODES, re.S)
    assert shown, "docs/nodes.md lacks the <!-- transitions --> table"
    assert shown.group(1).strip() == transitions_markdown()
