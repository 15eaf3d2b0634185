"""The unlabeled planner's parameters: checks, plan params."""

from __future__ import annotations

import pytest

from nodes.planner.unlabeled.config import UnlabeledConfig


@pytest.mark.parametrize("bad", [{"method": "magic"}, {"retrieval_method": "x"}, {"b": -1},
                                 {"weight": 0.5}, {"push_lengths": ()},
                                 {"push_lengths": (0.5, -1.0)}, {"max_proposals": 0}])
def test_bad_values_are_refused_naming_the_parameter(bad):
    with pytest.raises(ValueError, match="unlabeled"):
        UnlabeledConfig(**bad)


def test_plan_params_are_prefixed_like_the_ros_parameters():
    params = UnlabeledConfig(b=3).to_params()
    assert params["unlabeled.b"] == 3 and params["unlabeled.push_lengths"] == [0.5, 1.0]
    assert all(k.startswith("unlabeled.") for k in params)


def test_yaml_group_matches_the_dataclass_and_every_key_has_a_unit_comment():
    import dataclasses

    import yaml

    from nodes.common.paths import config_path
    from nodes.planner.cli import load_unlabeled_config

    text = config_path("planner.yaml").read_text()
    group = yaml.safe_load(text)["/**"]["ros__parameters"]["unlabeled"]
    defaults = {f.name: f.default for f in dataclasses.fields(UnlabeledConfig)}
    assert {k: tuple(v) if isinstance(v, list) else v for k, v in group.items()} == defaults
    lines = text.split("    unlabeled:", 1)[1].splitlines()[1:]
    assert lines and all("# [" in line for line in lines if line.strip())
    assert load_unlabeled_config(None, {}) == UnlabeledConfig()
    assert load_unlabeled_config(None, {"unlabeled.b": 3}).b == 3
    with pytest.raises(ValueError, match=r"unlabeled\.nope"):
        load_unlabeled_config(None, {"unlabeled.nope": 1})
