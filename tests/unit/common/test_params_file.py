"""One reader of ROS parameter files for every CLI: sections, nesting, strict names."""

from __future__ import annotations

import pytest

from nodes.common.params import configs_from_parameters, read_params_file
from nodes.planner.cli import PLANNER_PARAMETERS
from nodes.sim.config import SIM_PARAMETERS, load_sim_configs


def write(tmp_path, text: str):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    return path


def test_sections_apply_to_their_node_and_nesting_means_dots(tmp_path):
    path = write(tmp_path, "/**:\n  ros__parameters:\n    camera: {fx: 900.0}\n"
                           "sim:\n  ros__parameters:\n    seed: 4\n"
                           "/planner:\n  ros__parameters:\n    a1: 2.0\n")
    assert read_params_file(path, "sim") == {"camera.fx": 900.0, "seed": 4}
    assert read_params_file(path, "planner") == {"camera.fx": 900.0, "a1": 2.0}
    assert read_params_file(path) == {"camera.fx": 900.0, "seed": 4, "a1": 2.0}


def test_a_file_that_is_not_a_parameter_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="ros__parameters"):
        read_params_file(write(tmp_path, "sim:\n  seed: 3\n"))


def test_unknown_names_are_refused_and_types_coerced(tmp_path):
    sim, camera, _ = configs_from_parameters(
        SIM_PARAMETERS, {"seed": 5, "camera.fx": 1000, "use_sim_time": True}, "x.yaml")
    assert sim.seed == 5 and camera.fx == 1000.0 and isinstance(camera.fx, float)
    with pytest.raises(ValueError, match=r"x.yaml: unknown parameter\(s\) \['camera.fxx'\]"):
        configs_from_parameters(SIM_PARAMETERS, {"camera.fxx": 1.0}, "x.yaml")
    with pytest.raises(ValueError, match="budget_s"):
        configs_from_parameters(PLANNER_PARAMETERS, {"budget_s": "soon"}, "x.yaml")
    with pytest.raises(ValueError, match=r"x\.yaml: .*budget_s"):
        configs_from_parameters(PLANNER_PARAMETERS, {"budget_s": -1.0}, "x.yaml")


def test_the_sims_own_file_reads_back_as_its_defaults():
    from nodes.sim.config import CameraConfig, RandomSceneConfig, SimConfig

    assert load_sim_configs() == (SimConfig(), CameraConfig(), RandomSceneConfig())
