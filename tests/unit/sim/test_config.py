"""config/sim.yaml agrees with the dataclass defaults; the camera calibration file is calibrated."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

from nodes.common.paths import config_path
from nodes.sim.config import CameraConfig, RandomSceneConfig, SimConfig


def _params(name: str) -> dict:
    return yaml.safe_load(config_path(name).read_text())["/**"]["ros__parameters"]


@pytest.mark.parametrize(("cls", "section"), [(SimConfig, None), (CameraConfig, "camera"),
                                              (RandomSceneConfig, "random")])
def test_sim_yaml_matches_the_defaults(cls, section):
    params = _params("sim.yaml")
    values = params[section] if section else params
    for f in dataclasses.fields(cls):
        assert f.name in values, f"{section or ''}.{f.name} missing from config/sim.yaml"
        default, value = f.default, values[f.name]
        if isinstance(default, tuple):
            assert np.allclose(default, value), f.name
        else:
            assert value == default, f.name


def test_calibration_file_holds_a_calibration_not_the_true_pose():
    # densepack-calibrate's result (issue 4): close to the true pose, never a copy of it
    from nodes.common.camera_model import load_camera_pose

    calibrated = load_camera_pose(config_path("camera_calibration.yaml"))
    true = CameraConfig()
    offset = np.linalg.norm(np.subtract(calibrated.position, true.position))
    assert 1e-6 < offset < 0.002
    cos_half = abs(float(np.dot(calibrated.orientation_xyzw, true.orientation_xyzw)))
    angle_deg = np.degrees(2 * np.arccos(min(1.0, cos_half)))
    assert angle_deg < 0.2


def test_bad_values_are_refused():
    with pytest.raises(ValueError, match="physics_rate_hz"):
        SimConfig(physics_rate_hz=100.0)
    with pytest.raises(ValueError, match="grip_force"):
        SimConfig(grip_force=500.0)
