"""Planner parameters: YAML defaults agree with the dataclass, cross-checks refuse nonsense."""

from __future__ import annotations

import dataclasses

import pytest
import yaml

from nodes.common.paths import config_path
from nodes.planner.cli import load_config
from nodes.planner.config import PlannerConfig


def test_yaml_defaults_match_the_dataclass_and_every_key_has_a_unit_comment():
    text = config_path("planner.yaml").read_text()
    values = yaml.safe_load(text)["/**"]["ros__parameters"]
    defaults = {f.name: f.default for f in dataclasses.fields(PlannerConfig)}
    assert values == defaults
    for line in text.splitlines():
        if line.startswith("    ") and ":" in line:
            assert "# [" in line, line
    assert load_config(None, {}) == PlannerConfig()


def test_cross_checks_refuse_a_gripper_that_cannot_work():
    with pytest.raises(ValueError, match="stroke"):
        PlannerConfig(approach_clearance=0.02).check_block(0.0508)
    with pytest.raises(ValueError, match="rear face"):
        PlannerConfig(push_opening=0.04).check_block(0.0508)
    with pytest.raises(ValueError, match="eps"):
        PlannerConfig(eps=1.5)
    with pytest.raises(ValueError, match="budget_s"):
        PlannerConfig(budget_s=0.0)
