"""The detector's parameters (one frozen dataclass; declared as ROS parameters by the node).

Defaults agree with ``config/detector.yaml`` (a test checks it). The camera pose comes from
``config/camera_calibration.yaml`` (``camera_pose.*``, written by densepack-calibrate): pass
it as a second ``--params-file``, or leave the pose unset and the node reads
``calibration_file`` itself. The detector never looks at the simulator's true camera pose.
"""

from __future__ import annotations

from dataclasses import dataclass

from msgs_py import MessageError
from msgs_py.camera import CAMERA_RELIABILITIES, CameraPose
from msgs_py.cell import BLOCK_SIZE, TAG_SIZE
from nodes.common.params import param
from nodes.detector.estimate import ESTIMATORS
from nodes.detector.id_sets import parse_id_set
from nodes.detector.tags import REFINEMENTS
from nodes.robot.silhouette import MARGIN_PX

UNSET_POSITION = (0.0, 0.0, 0.0)
UNSET_ORIENTATION = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class DetectorConfig:
    refinement: str = param(
        "edges", "corner refinement: edges (sub-pixel side line fits), apriltag, subpix, none")
    decimate: float = param(
        1.0, "coarse tag search on the image shrunk by this factor (>= 1); corners are "
        "always refined at full resolution")
    pose_method: str = param(
        "plane", "block pose from corners: plane (rays meet the tag plane z = block_size) "
        "or pnp (free 6-DoF pose per tag)")
    max_reprojection_px: float = param(
        1.0, "tags whose fitted pose reprojects worse than this (RMS over corners) are "
        "dropped", unit="px")
    allowed_ids: str = param(
        "0-586", "tag ids that are blocks, e.g. '0-24,30'; other ids are warned about and "
        "dropped")
    expected_ids: str = param(
        "", "ids known from the start (reported in 'missing' until seen), e.g. '0-8'; ids "
        "seen since start or the last ~/reset are known too")
    image_reliability: str = param(
        "reliable", "QoS reliability of the image/camera_info subscriptions: reliable (the "
        "sim's default camera; best effort lost one 3.7 MB frame in three under load) or "
        "best_effort (hears a publisher of either kind: a camera driver's sensor-data QoS, "
        "the sim's camera.reliability best_effort)")
    image_rectified: bool = param(
        False, "false: raw images (/camera/image_raw), undistorted with camera_info's k, d "
        "and distortion_model; true: rectified images (image_proc's /camera/image_rect), "
        "imaged by camera_info's p with no distortion")
    block_size: float = param(BLOCK_SIZE, "cube side; tags lie in the plane z = block_size",
                              unit="m")
    tag_size: float = param(TAG_SIZE, "side of the tag's black square", unit="m")
    correct_from_placements: bool = param(
        True, "compare where the arm reports setting blocks down (/executor/placements) with "
        "where the camera then sees them, and correct the perceived poses when the two "
        "disagree (a bumped or roughly calibrated camera); false: publish as calibrated")
    robot_occlusion: bool = param(
        True, "read the robot's joint states (/joint_states, /gripper/joint_states) and "
        "report the blocks whose tags the arm or the gripper covers in a frame as occluded "
        "(not judged from it) instead of seen or missing; false: no robot in view")
    occlusion_margin_px: float = param(
        MARGIN_PX, "the robot's silhouette and each tag are grown by this before they are "
        "compared (joint state timing, calibration error, the model's simplicity)", unit="px")
    calibration_check_max_age_h: float = param(
        24.0, "a camera check (the executor's grips in place, placements that agree) younger "
        "than this, for this calibration, counts: the detector starts with its correction and "
        "says the calibration is checked, so the executor skips its camera check (0 = never)",
        unit="h")
    calibration_file: str = param(
        "camera_calibration.yaml", "calibration YAML read when camera_pose.* is not set "
        "(relative paths are under config/)")
    camera_position: tuple[float, ...] = param(
        UNSET_POSITION, "camera_optical_frame origin in world (from the calibration file; "
        "all zero = read calibration_file)", unit="m", name="camera_pose.position")
    camera_orientation_xyzw: tuple[float, ...] = param(
        UNSET_ORIENTATION, "camera_optical_frame orientation in world, quaternion x, y, z, w "
        "(all zero = read calibration_file)", name="camera_pose.orientation_xyzw")

    def __post_init__(self) -> None:
        if self.refinement not in REFINEMENTS:
            raise ValueError(f"parameter 'refinement': '{self.refinement}' is not one of "
                             f"{sorted(REFINEMENTS)}")
        if self.pose_method not in ESTIMATORS:
            raise ValueError(f"parameter 'pose_method': '{self.pose_method}' is not one of "
                             f"{sorted(ESTIMATORS)}")
        if self.image_reliability not in CAMERA_RELIABILITIES:
            raise ValueError(f"parameter 'image_reliability': '{self.image_reliability}' is "
                             f"not one of {list(CAMERA_RELIABILITIES)}")
        if not self.decimate >= 1.0:
            raise ValueError(f"parameter 'decimate': must be >= 1, got {self.decimate}")
        if not self.max_reprojection_px > 0.0:
            raise ValueError("parameter 'max_reprojection_px': must be > 0")
        if not 0.0 < self.tag_size < self.block_size:
            raise ValueError(f"parameters 'tag_size' ({self.tag_size}) and 'block_size' "
                             f"({self.block_size}): need 0 < tag_size < block_size")
        allowed = parse_id_set(self.allowed_ids, "allowed_ids")
        expected = parse_id_set(self.expected_ids, "expected_ids")
        if not expected <= allowed:
            raise ValueError(f"parameter 'expected_ids': ids {sorted(expected - allowed)} "
                             "are not in allowed_ids")
        self.camera_pose_from_parameters()  # a malformed pose fails at startup

    def camera_pose_from_parameters(self) -> CameraPose | None:
        """The pose given as parameters, or None when they are left unset (all zero).

        Raises:
            ValueError: a pose that is set but malformed (names the parameter).
        """
        if all(v == 0.0 for v in self.camera_orientation_xyzw):
            return None
        try:
            return CameraPose(tuple(self.camera_position), tuple(self.camera_orientation_xyzw))
        except MessageError as err:
            raise ValueError(f"parameter {err}") from None
