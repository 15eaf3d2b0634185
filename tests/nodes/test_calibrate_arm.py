"""densepack-calibrate mode arm against the sim node (through the arm and gripper nodes, as on
a real cell), in-process: the arm sets one block down at known placements and the camera pose,
5 mm / 0.5 deg off to start with, is recovered."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from rclpy.parameter import Parameter

from msgs_py.camera import CameraPose
from nodes.arm.node import ArmNode
from nodes.calibration.arm_routine import DEFAULT_PLACEMENTS
from nodes.calibration.cli import CalibrateNode
from nodes.common.camera_model import CameraModel, load_camera_pose, save_camera_pose
from nodes.common.transforms import quaternion_to_matrix, rotation_angle
from nodes.gripper.node import GripperNode
from nodes.sim.config import CameraConfig
from nodes.sim.node import SimNode

pytestmark = pytest.mark.ros


def table_error_mm(a: CameraModel, b: CameraModel) -> float:
    """Largest distance (mm) between where the two cameras put the same pixel on the tag
    plane, over the workspace's part of the image."""
    grid = np.array([[x, y, 0.0508] for x in np.linspace(0.45, 0.95, 6)
                     for y in np.linspace(-0.35, 0.35, 8)])
    pixels = a.project(grid)
    return 1e3 * float(np.max(np.linalg.norm(
        a.intersect_plane_z(pixels, 0.0508) - b.intersect_plane_z(pixels, 0.0508), axis=1)))


# One of six clean-clone CI runs with this gate set blocks down 0.6-0.9 mm off the TCP at
# release (RMS 0.66 px, the camera 0.14 deg off, 2026-12-05): the tool then refuses to write
# and the operator runs it again, as the rerun does. Why a block settles that far from the TCP
# at release is not yet understood; the asserts themselves stay.
@pytest.mark.flaky(reruns=1)
def test_the_arm_routine_recovers_a_camera_5_mm_and_half_a_degree_off(ros, tmp_path):
    """The routine as a user runs it: the nine default placements, one frame each. (With five,
    one block settling half a millimetre from the TCP at release, seen once in CI, moved the
    solved camera 0.47 mm on the table and 0.13 deg.)"""
    camera = CameraConfig()
    true = CameraModel.from_pose(camera.model().intrinsics,
                                 CameraPose(tuple(camera.position),
                                            tuple(camera.orientation_xyzw)))
    tilt = cv2.Rodrigues(np.radians(0.5) * np.array([0.6, -0.8, 0.0]))[0]
    off_rotation = tilt @ quaternion_to_matrix(camera.orientation_xyzw)
    off = CameraModel(true.intrinsics, off_rotation,
                      true.position + np.array([0.003, -0.004, 0.0]))
    start = tmp_path / "start.yaml"
    save_camera_pose(start, off.pose)
    assert table_error_mm(true, off) > 5.0  # the calibration the routine starts from
    out = tmp_path / "camera_calibration.yaml"
    ros.add(SimNode(context=ros.context, parameter_overrides=[
        Parameter("scene_file", value="scenes/calibration_arm.yaml"),
        Parameter("camera.rate_hz", value=0.0)]))
    sim_time = [Parameter("use_sim_time", value=True)]
    ros.add(ArmNode(context=ros.context, parameter_overrides=sim_time))
    ros.add(GripperNode(context=ros.context, parameter_overrides=sim_time))
    node = ros.add(CalibrateNode(context=ros.context, parameter_overrides=[
        Parameter("use_sim_time", value=True), Parameter("mode", value="arm"),
        Parameter("calibration_file", value=str(start)),
        Parameter("output_file", value=str(out)),
        Parameter("arm.frames", value=1)]))
    assert node.done.wait(600.0)
    assert node.routine.error == ""
    result = node.solve()
    assert result.n_frames == len(DEFAULT_PLACEMENTS) // 3 and not result.dropped_tags
    # The residual is the tool's own gate (densepack-calibrate writes nothing above
    # max_rms_px); the accuracy asserted below is what the routine is for. It is mostly where
    # the block settles against the TCP at release, not the corners: with the sim's true block
    # poses the same frames leave 0.07-0.10 px, with the TCP's 0.13-0.18 px (five runs here,
    # the far row 0.10-0.16 mm off the TCP) and 0.31 px in two CI runs, whose cameras agreed
    # with these to 0.6 mm. The report in the message makes a failure diagnosable alone.
    assert result.rms_px < node.config.max_rms_px, f"{result.report()}\n{node.routine.report()}"
    node.write(result)
    got = CameraModel.from_pose(true.intrinsics, load_camera_pose(out))
    error = table_error_mm(true, got)
    print(f"table error: {table_error_mm(true, off):.2f} mm before, {error:.3f} mm after; "
          f"camera position off by {1e3 * np.linalg.norm(got.position - true.position):.2f}"
          f" mm; RMS {result.rms_px:.3f} px\n{node.routine.report()}")
    assert error < 0.5
    assert math.degrees(rotation_angle(got.rotation, true.rotation)) < 0.1
