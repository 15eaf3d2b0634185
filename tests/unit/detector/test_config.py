"""Detector and calibration parameters: defaults agree with config/, bad values fail loudly."""

from __future__ import annotations

import dataclasses

import pytest
import yaml

from nodes.calibration.cli import CalibrateConfig
from nodes.common.camera_model import load_camera_pose
from nodes.common.params import config_overrides
from nodes.common.paths import config_path
from nodes.detector.config import DetectorConfig


def yaml_parameters(name: str) -> dict:
    data = yaml.safe_load(config_path(name).read_text())
    return data["/**"]["ros__parameters"]


def test_detector_yaml_matches_the_dataclass_defaults():
    defaults = config_overrides(DetectorConfig())
    in_yaml = yaml_parameters("detector.yaml")
    for name, value in in_yaml.items():
        assert defaults[name] == value, name
    # everything but the camera pose (which lives in camera_calibration.yaml) is in the file
    assert set(defaults) - set(in_yaml) == {"camera_pose.position",
                                            "camera_pose.orientation_xyzw"}


def test_every_detector_yaml_key_has_a_comment():
    for line in config_path("detector.yaml").read_text().splitlines():
        if ":" in line and line.startswith("    "):
            assert "#" in line, line


def test_the_calibration_file_is_readable():
    load_camera_pose(config_path("camera_calibration.yaml"))


@pytest.mark.parametrize("field,value,match", [
    ("refinement", "magic", "refinement"),
    ("pose_method", "guess", "pose_method"),
    ("decimate", 0.5, "decimate"),
    ("allowed_ids", "3-1", "allowed_ids"),
    ("expected_ids", "30", "expected_ids"),
    ("camera_orientation_xyzw", (0.0, 0.0, 0.0, 3.0), "orientation"),
])
def test_bad_parameters_are_refused_naming_the_parameter(field, value, match):
    overrides = {field: value}
    if field == "expected_ids":
        overrides["allowed_ids"] = "0-9"
    with pytest.raises(ValueError, match=match):
        dataclasses.replace(DetectorConfig(), **overrides)


def test_calibrate_defaults_name_existing_files():
    config = CalibrateConfig()
    assert config_path(config.known_poses_file).exists()
