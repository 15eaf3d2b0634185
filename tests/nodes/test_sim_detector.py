"""sim -> detector -> /blocks/detected, and densepack-calibrate against the sim, in-process."""

from __future__ import annotations

import math

import numpy as np
import pytest
from densepack_interfaces.msg import BlockPoseArray
from rclpy.parameter import Parameter
from sensor_msgs.msg import CameraInfo

from msgs_py.ros import block_set_from_msg, stamp_to_ns
from nodes.bench.perception_frames import LENSES
from nodes.calibration.cli import CalibrateNode
from nodes.common.camera_model import load_camera_pose
from nodes.common.paths import config_path
from nodes.common.qos import camera_qos
from nodes.common.transforms import quaternion_to_matrix, rotation_angle
from nodes.detector.node import DetectorNode
from nodes.sim.node import SimNode

pytestmark = pytest.mark.ros


def calibration_params() -> list[Parameter]:
    pose = load_camera_pose(config_path("camera_calibration.yaml"))
    return [Parameter("camera_pose.position", value=list(pose.position)),
            Parameter("camera_pose.orientation_xyzw", value=list(pose.orientation_xyzw))]


def test_sim_frames_become_detections_matching_the_ground_truth(ros):
    sim = ros.add(SimNode(context=ros.context))
    ros.add(DetectorNode(context=ros.context, parameter_overrides=calibration_params()))
    assert_detections_match_the_truth(ros, sim)


def test_the_default_camera_publishes_a_rational_calibration_with_p_apart_from_k(ros):
    ros.add(SimNode(context=ros.context))
    info = ros.wait_for_message("/camera/camera_info", CameraInfo, timeout=30,
                                qos=camera_qos("reliable"))
    assert info.distortion_model == "rational_polynomial" and len(info.d) == 8
    assert abs(info.p[0] - info.k[0]) > 10.0  # p: the optimal new camera matrix, not k


def test_a_driver_like_fisheye_camera_on_best_effort_is_detected(ros):
    """The sim as a camera driver with sensor-data (best-effort) QoS and an equidistant
    calibration; the detector subscribes best effort."""
    lens = LENSES["equidistant"]
    sim = ros.add(SimNode(context=ros.context, parameter_overrides=[
        Parameter("camera.distortion_model", value=lens.model),
        Parameter("camera.distortion", value=list(lens.d)),
        Parameter("camera.reliability", value="best_effort")]))
    ros.add(DetectorNode(context=ros.context, parameter_overrides=[
        *calibration_params(), Parameter("image_reliability", value="best_effort")]))
    info = ros.wait_for_message("/camera/camera_info", CameraInfo, timeout=30,
                                qos=camera_qos("best_effort"))
    assert info.distortion_model == "equidistant" and len(info.d) == 4
    assert_detections_match_the_truth(ros, sim)


def assert_detections_match_the_truth(ros, sim) -> None:
    ids = sorted(b.id for b in sim.scene.blocks)
    msg = ros.wait_for_message("/blocks/detected", BlockPoseArray, timeout=60,
                               predicate=lambda m: len(m.blocks) == len(ids))
    detected = block_set_from_msg(msg)
    assert detected.ids == ids and detected.missing == ()
    stamp = stamp_to_ns(msg.header.stamp)
    truth = block_set_from_msg(ros.wait_for_message(
        "/sim/ground_truth", BlockPoseArray, timeout=30,
        predicate=lambda m: stamp_to_ns(m.header.stamp) >= stamp))
    for b in truth.blocks:  # the blocks rest: the truth a little later is the truth then
        got = detected.by_id()[b.id]
        assert math.hypot(got.x - b.x, got.y - b.y) < 1e-3
        assert abs(math.degrees(math.remainder(got.theta - b.theta, 2 * math.pi))) < 0.5


def test_calibrate_recovers_the_sim_camera_pose(ros, tmp_path):
    sim = ros.add(SimNode(context=ros.context, parameter_overrides=[
        Parameter("scene_file", value="scenes/calibration.yaml")]))
    node = ros.add(CalibrateNode(context=ros.context, parameter_overrides=[
        Parameter("frames", value=3), Parameter("output_file", value=str(tmp_path / "c.yaml"))]))
    assert node.done.wait(60.0)
    result = node.solve()
    true = sim.camera_config
    assert np.linalg.norm(result.camera.position - np.asarray(true.position)) < 2e-3
    assert math.degrees(rotation_angle(result.camera.rotation,
                                       quaternion_to_matrix(true.orientation_xyzw))) < 0.2
    node.write(result)
    assert load_camera_pose(tmp_path / "c.yaml").position == pytest.approx(
        tuple(result.camera.position), abs=1e-6)
