"""Tag finding and corner refinement on rendered images with exactly known corners."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from msgs_py import BlockPose
from nodes.detector.synthetic import RenderStyle, overhead_camera, render_blocks
from nodes.detector.tag_geometry import tag_corners_world
from nodes.detector.tags import FinderSettings, TagFinder

CAMERA = overhead_camera()
BLOCKS = [BlockPose(i, 0.50 + 0.1 * (i % 5), -0.30 + 0.15 * (i // 5), 0.37 * i - 1.5)
          for i in range(0, 20)]


@pytest.fixture(scope="module")
def noisy_gray():
    image = render_blocks(CAMERA, BLOCKS, RenderStyle(noise_std=2.0, blur_sigma_px=0.6),
                          rng=np.random.default_rng(7))
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


def corner_errors(detections) -> np.ndarray:
    truth = {b.id: CAMERA.project(tag_corners_world(b)) for b in BLOCKS}
    return np.concatenate([np.linalg.norm(d.corners - truth[d.tag_id], axis=1)
                           for d in detections])


@pytest.mark.parametrize("refinement", ["edges", "subpix", "none"])
def test_every_tag_is_found_with_its_id(noisy_gray, refinement):
    detections = TagFinder(FinderSettings(refinement)).find(noisy_gray)
    assert sorted(d.tag_id for d in detections) == [b.id for b in BLOCKS]


def test_edge_fit_corners_are_sub_tenth_pixel(noisy_gray):
    edges = corner_errors(TagFinder(FinderSettings("edges")).find(noisy_gray))
    plain = corner_errors(TagFinder(FinderSettings("none")).find(noisy_gray))
    assert np.median(edges) < 0.08 and edges.max() < 0.3
    assert np.median(edges) < 0.25 * np.median(plain)


def test_decimated_search_keeps_full_resolution_accuracy(noisy_gray):
    detections = TagFinder(FinderSettings("edges", decimate=1.5)).find(noisy_gray)
    assert len(detections) == len(BLOCKS)
    assert np.median(corner_errors(detections)) < 0.08


def test_blank_image_has_no_tags():
    assert TagFinder().find(np.full((480, 640), 128, np.uint8)) == []


def test_unknown_refinement_is_refused():
    with pytest.raises(ValueError, match="unknown corner refinement"):
        TagFinder(FinderSettings("magic"))
