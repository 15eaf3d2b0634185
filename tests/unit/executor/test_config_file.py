"""config/executor.yaml states exactly the dataclass defaults (one source of truth)."""

from __future__ import annotations

import yaml

from nodes.common.params import config_overrides
from nodes.common.paths import config_path
from nodes.executor.config import ExecutorConfig


def test_yaml_defaults_match_the_dataclass():
    data = yaml.safe_load(config_path("executor.yaml").read_text())["/**"]["ros__parameters"]
    assert data == config_overrides(ExecutorConfig())
