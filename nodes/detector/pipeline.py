"""One overhead image -> the blocks seen in it, with the bookkeeping a consumer needs.

``BlockDetector`` finds the tags, refuses what cannot be trusted (ids outside the allowed
set, an id seen twice in one frame, a fit whose reprojection error is above threshold) and
tells seen blocks from known blocks that are *not* seen in this frame. Given the robot's pose
at the frame's stamp (``nodes.detector.robot_view``), the blocks whose tags the robot covers,
wholly or partly, are ``occluded``: seen or not, they are not judged from this frame (a
finger over one side of a tag bends its fitted edge). Known blocks neither seen nor covered
are ``missing``. "Known" = the ``expected_ids`` given up front plus every id seen since start
or since ``reset()``; where a block was last seen (uncovered), or where the arm set it down
or pushed it since (``on_placed``), tells whether the robot covers it now. Every refusal
comes back as a ``FrameWarning`` (its kind and the text) for the node to log.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field

import cv2
import numpy as np

from msgs_py import BlockPose, BlockSet
from msgs_py.camera import CameraIntrinsics, CameraPose
from nodes.common.camera_model import CameraModel
from nodes.detector.config import DetectorConfig
from nodes.detector.estimate import ESTIMATORS
from nodes.detector.id_sets import format_id_set, parse_id_set
from nodes.detector.robot_view import RobotPose, covered_blocks
from nodes.detector.tag_geometry import tag_corners_world
from nodes.detector.tags import FinderSettings, TagDetection, TagFinder
from nodes.detector.warning_kinds import WarningKind


@dataclass(frozen=True)
class FrameWarning:
    """Something of a frame refused, and why, in words."""

    kind: WarningKind
    text: str


@dataclass(frozen=True)
class FrameResult:
    """The outcome of one frame: the block set to publish and what was refused and why."""

    blocks: BlockSet
    warnings: tuple[FrameWarning, ...] = ()
    detections: tuple[TagDetection, ...] = ()
    detect_s: float = 0.0  # wall time from pixels to poses
    rejected: dict[int, str] = field(default_factory=dict)


def to_gray(image: np.ndarray, encoding: str = "rgb8") -> np.ndarray:
    """An 8-bit grey view of an rgb8/bgr8/rgba8/bgra8/mono8 array."""
    if image.ndim == 2:
        return image
    code = {
        "rgb8": cv2.COLOR_RGB2GRAY, "bgr8": cv2.COLOR_BGR2GRAY,
        "rgba8": cv2.COLOR_RGBA2GRAY, "bgra8": cv2.COLOR_BGRA2GRAY,
    }[encoding]
    return cv2.cvtColor(image, code)


class BlockDetector:
    """Tags -> block poses in ``world`` for a camera at a calibrated pose."""

    def __init__(self, config: DetectorConfig, camera_pose: CameraPose) -> None:
        self.config = config
        self.camera_pose = camera_pose
        self.finder = TagFinder(FinderSettings(config.refinement, config.decimate))
        self.estimator = ESTIMATORS[config.pose_method]
        self.allowed = parse_id_set(config.allowed_ids, "allowed_ids")
        self.expected = parse_id_set(config.expected_ids, "expected_ids")
        self.seen: set[int] = set()
        self.last_seen: dict[int, BlockPose] = {}  #: where each block was last seen uncovered
        self._placed: list[tuple[int, BlockPose]] = []  #: (stamp ns, pose) not yet in last_seen
        self._camera: CameraModel | None = None

    @property
    def known(self) -> frozenset[int]:
        return frozenset(self.expected | self.seen)

    def reset(self) -> None:
        """Forget the blocks seen so far (a new scene); ``expected_ids`` stay known."""
        self.seen.clear()
        self.last_seen.clear()
        self._placed.clear()

    def on_placed(self, block: BlockPose, stamp_ns: int) -> None:
        """The arm set ``block`` down (or pushed it) at ``stamp_ns``. In frames taken from
        then on, until one shows it, the robot covers it or not where the arm left it, not
        where it was last seen before it was picked: the arm rises from a block it has just
        let go, so the first frame on its way often has it under the arm, and judged where
        it stood before it would be called missing (the executor then looked again from the
        park pose, 1-7 times in a 16-block scene). The pose is the arm's (world), not the
        camera's: a calibration error of a few mm is within ``occlusion_margin_px``."""
        self._placed.append((stamp_ns, block))

    def _take_placed(self, stamp_ns: int) -> None:
        """Where the blocks set down by ``stamp_ns`` stand, into ``last_seen``."""
        due = [(t, b) for t, b in self._placed if t <= stamp_ns]
        self._placed = [(t, b) for t, b in self._placed if t > stamp_ns]
        for _, block in sorted(due, key=lambda placed: placed[0]):
            self.last_seen[block.id] = block

    def camera(self, intrinsics: CameraIntrinsics) -> CameraModel:
        if self._camera is None or self._camera.intrinsics != intrinsics:
            self._camera = CameraModel.from_pose(intrinsics, self.camera_pose)
        return self._camera

    def process(self, image: np.ndarray, intrinsics: CameraIntrinsics, stamp_ns: int,
                encoding: str = "rgb8", robot: RobotPose | None = None) -> FrameResult:
        """Detect the blocks in one image (H x W [x C], 8 bit) taken at ``stamp_ns``, with
        the robot at ``robot`` then (None: unknown, nothing counts as covered)."""
        start = time.perf_counter()
        camera = self.camera(intrinsics)
        detections = self.finder.find(to_gray(image, encoding))
        warnings: list[FrameWarning] = []
        rejected: dict[int, str] = {}
        counts = Counter(d.tag_id for d in detections)
        unknown = sorted(i for i in counts if i not in self.allowed)
        if unknown:
            warnings.append(FrameWarning(
                WarningKind.UNKNOWN_ID,
                f"tag id(s) {unknown} outside allowed_ids '{self.config.allowed_ids}': dropped"))
        duplicates = sorted(i for i, n in counts.items() if n > 1 and i in self.allowed)
        if duplicates:
            warnings.append(FrameWarning(
                WarningKind.DUPLICATE_ID, f"tag id(s) {duplicates} seen more than once in one "
                "frame: cannot tell the blocks apart, all copies dropped"))
            rejected.update({i: "duplicate" for i in duplicates})
        blocks: list[BlockPose] = []
        corners: dict[int, np.ndarray] = {}
        reprojection: dict[int, float] = {}
        for det in detections:
            if det.tag_id not in self.allowed or det.tag_id in rejected:
                continue
            est = self.estimator(camera, det.corners, self.config.block_size,
                                 self.config.tag_size)
            if not est.finite or est.reprojection_px > self.config.max_reprojection_px:
                rejected[det.tag_id] = f"reprojection error {est.reprojection_px:.2f} px"
                warnings.append(FrameWarning(
                    WarningKind.REPROJECTION, f"tag {det.tag_id}: reprojection error "
                    f"{est.reprojection_px:.2f} px > max_reprojection_px "
                    f"{self.config.max_reprojection_px}: dropped"))
                continue
            blocks.append(BlockPose(det.tag_id, est.x, est.y, est.theta))
            corners[det.tag_id] = det.corners
            reprojection[det.tag_id] = round(est.reprojection_px, 4)
        self.seen |= {b.id for b in blocks} | set(rejected)
        self._take_placed(stamp_ns)
        covered = self._covered(camera, robot, corners)
        blocks = [b for b in blocks if b.id not in covered]
        self.last_seen.update({b.id: b for b in blocks})
        seen_now = {b.id for b in blocks}
        missing = tuple(sorted(self.known - seen_now - covered))
        occluded = tuple(sorted(covered & self.known))
        block_set = BlockSet(tuple(sorted(blocks, key=lambda b: b.id)), stamp_ns, "world",
                             self.config.block_size, missing,
                             {i: e for i, e in reprojection.items() if i in seen_now}, occluded)
        return FrameResult(block_set, tuple(warnings), tuple(detections),
                           time.perf_counter() - start, rejected)

    def _covered(self, camera: CameraModel, robot: RobotPose | None,
                 corners: dict[int, np.ndarray]) -> set[int]:
        """The known blocks the robot covers in this frame (none without its pose)."""
        if robot is None or not self.config.robot_occlusion:
            return set()
        unseen = {i: p for i, p in self.last_seen.items() if i not in corners}
        size = self.config.block_size
        return covered_blocks(
            robot, camera.project, lambda p: camera.to_camera(p)[:, 2], corners, unseen,
            lambda b: tag_corners_world(b, size, self.config.tag_size),
            self.config.occlusion_margin_px)

    def describe(self) -> str:
        return (f"refinement={self.config.refinement} decimate={self.config.decimate} "
                f"pose_method={self.config.pose_method} allowed_ids="
                f"{format_id_set(self.allowed) or '(none)'} expected_ids="
                f"{format_id_set(self.expected) or '(none)'}")
