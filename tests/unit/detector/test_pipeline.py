"""One frame -> BlockSet: exact ids and poses, refusals, occlusion bookkeeping."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from msgs_py import BlockPose
from nodes.detector.config import DetectorConfig
from nodes.detector.pipeline import BlockDetector
from nodes.detector.synthetic import RenderStyle, overhead_camera, render_blocks
from nodes.detector.warning_kinds import WarningKind

CAMERA = overhead_camera()
STYLE = RenderStyle(noise_std=2.0, blur_sigma_px=0.6)
#: A known scene: 9 blocks spread over the view, every yaw quadrant.
SCENE = [BlockPose(i, 0.50 + 0.2 * (i % 3), -0.28 + 0.28 * (i // 3), -3.0 + 0.7 * i)
         for i in range(9)]


def detector(**overrides) -> BlockDetector:
    return BlockDetector(dataclasses.replace(DetectorConfig(), **overrides), CAMERA.pose)


def render(blocks, **kwargs):
    return render_blocks(CAMERA, blocks, STYLE, rng=np.random.default_rng(5), **kwargs)


def test_known_image_gives_exact_ids_and_poses():
    result = detector().process(render(SCENE), CAMERA.intrinsics, stamp_ns=123)
    got = result.blocks.by_id()
    assert sorted(got) == [b.id for b in SCENE]
    for b in SCENE:
        assert math.hypot(got[b.id].x - b.x, got[b.id].y - b.y) < 0.3e-3
        assert abs(math.remainder(got[b.id].theta - b.theta, 2 * math.pi)) < math.radians(0.2)
        assert 0.0 <= result.blocks.reprojection_px[b.id] < 0.3
    assert result.blocks.stamp_ns == 123 and result.blocks.frame_id == "world"
    assert result.warnings == () and result.blocks.missing == ()


def test_the_lens_distortion_of_camera_info_is_undone():
    """The same scene through a lens: exact poses when camera_info carries ``d``; a pinhole
    reading of the same pixels is millimetres off towards the image's edges."""
    lens = overhead_camera(focal_px=1400.0, distortion=(-0.10, 0.08, 0.0002, -0.00015, 0.0))
    blocks = [*SCENE, BlockPose(9, 0.43, 0.37, 0.3), BlockPose(10, 0.97, -0.37, -0.8)]
    image = render_blocks(lens, blocks, STYLE, rng=np.random.default_rng(5))
    detector_ = BlockDetector(DetectorConfig(), lens.pose)
    got = detector_.process(image, lens.intrinsics, 1).blocks.by_id()
    assert sorted(got) == [b.id for b in blocks]
    for b in blocks:
        assert math.hypot(got[b.id].x - b.x, got[b.id].y - b.y) < 0.3e-3
    naive = detector_.process(image, lens.intrinsics.pinhole(), 2).blocks.by_id()
    assert max(math.hypot(naive[b.id].x - b.x, naive[b.id].y - b.y)
               for b in blocks if b.id in naive) > 2e-3


def test_yaw_follows_the_tag_not_the_cube_symmetry():
    # the tag fixes the block's x axis, so theta and theta + pi/2 are told apart
    blocks = [BlockPose(0, 0.6, 0.0, 0.1), BlockPose(1, 0.8, 0.0, 0.1 + math.pi / 2)]
    got = detector().process(render(blocks), CAMERA.intrinsics, 1).blocks.by_id()
    assert got[0].theta == pytest.approx(0.1, abs=0.005)
    assert got[1].theta == pytest.approx(0.1 + math.pi / 2, abs=0.005)


def test_duplicate_ids_are_both_dropped_with_a_warning():
    blocks = [BlockPose(4, 0.6, -0.1, 0.0), BlockPose(4, 0.8, 0.1, 0.5),
              BlockPose(5, 0.7, 0.2, 0.0)]
    result = detector().process(render(blocks), CAMERA.intrinsics, 1)
    assert result.blocks.ids == [5]
    assert [w.kind for w in result.warnings] == [WarningKind.DUPLICATE_ID]
    assert "more than once" in result.warnings[0].text
    assert result.blocks.missing == (4,)


def test_unknown_ids_are_dropped_with_a_warning():
    blocks = [BlockPose(3, 0.6, -0.1, 0.0), BlockPose(42, 0.8, 0.1, 0.5)]
    result = detector(allowed_ids="0-24").process(render(blocks), CAMERA.intrinsics, 1)
    assert result.blocks.ids == [3]
    assert [w.kind for w in result.warnings] == [WarningKind.UNKNOWN_ID]
    assert "42" in result.warnings[0].text and "allowed_ids" in result.warnings[0].text
    assert result.blocks.missing == ()


def test_blocks_hidden_by_the_arm_are_reported_missing():
    det = detector()
    det.process(render(SCENE), CAMERA.intrinsics, 1)
    hidden = SCENE[4]
    arm = np.array([[hidden.x - 0.05, hidden.y - 0.05, 0.3], [hidden.x + 0.05, hidden.y - 0.05,
                    0.3], [hidden.x + 0.05, hidden.y + 0.05, 0.3],
                    [hidden.x - 0.05, hidden.y + 0.05, 0.3]])
    result = det.process(render(SCENE, occluders=[arm]), CAMERA.intrinsics, 2)
    assert result.blocks.missing == (hidden.id,)
    assert hidden.id not in result.blocks.ids and len(result.blocks.blocks) == 8
    det.reset()
    result = det.process(render(SCENE, occluders=[arm]), CAMERA.intrinsics, 3)
    assert result.blocks.missing == ()  # forgotten after a reset


def test_expected_ids_are_missing_until_seen():
    det = detector(expected_ids="0-9")
    result = det.process(render(SCENE), CAMERA.intrinsics, 1)
    assert result.blocks.missing == (9,)


def test_tags_above_the_reprojection_threshold_are_dropped():
    det = detector(max_reprojection_px=0.01)
    result = det.process(render(SCENE[:2]), CAMERA.intrinsics, 1)
    assert result.blocks.blocks == () and len(result.rejected) == 2
    assert [w.kind for w in result.warnings] == [WarningKind.REPROJECTION] * 2
    assert all("reprojection" in w.text for w in result.warnings)


def test_a_block_carried_above_the_table_is_not_reported():
    carried = BlockPose(7, 0.7, 0.0, 0.2)
    image = render_blocks(CAMERA, [carried], STYLE, block_size=0.0508 + 0.15)
    result = detector().process(image, CAMERA.intrinsics, 1)
    assert result.blocks.blocks == () and 7 in result.rejected


def test_other_encodings_and_grey_images_work():
    image = render(SCENE[:3])
    det = detector()
    bgr = det.process(image[:, :, ::-1].copy(), CAMERA.intrinsics, 1, encoding="bgr8")
    mono = det.process(image[:, :, 0].copy(), CAMERA.intrinsics, 2, encoding="mono8")
    assert bgr.blocks.ids == mono.blocks.ids == [0, 1, 2]


def test_pnp_method_is_selectable_by_name():
    result = detector(pose_method="pnp").process(render(SCENE[:3]), CAMERA.intrinsics, 1)
    assert result.blocks.ids == [0, 1, 2]
