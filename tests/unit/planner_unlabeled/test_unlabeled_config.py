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
