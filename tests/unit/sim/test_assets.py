"""The committed assets are exactly what sim_assets/make_assets.py generates."""

from __future__ import annotations

import importlib.util

import cv2
import numpy as np
import pytest

from nodes.common.paths import asset_path
from nodes.sim import robot_model as rm


@pytest.fixture(scope="module")
def make_assets():
    spec = importlib.util.spec_from_file_location("make_assets", asset_path("make_assets.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_urdf_and_block_mesh_are_up_to_date(make_assets):
    assert asset_path("ur10e_2f85.urdf").read_text() == make_assets.arm_urdf()
    assert asset_path("block.obj").read_text() == make_assets.block_obj()


@pytest.mark.parametrize("tag_id", [0, 7, 49])
def test_tag_textures_are_up_to_date_and_decode_to_their_id(make_assets, tag_id):
    on_disk = cv2.imread(str(asset_path(f"tags/tag36h11_{tag_id:03d}.png")))[..., ::-1]
    assert np.array_equal(on_disk, make_assets.tag_texture(tag_id))
    face = on_disk[:make_assets.FACE_PX, :make_assets.FACE_PX]
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    _, ids, _ = cv2.aruco.ArucoDetector(dictionary).detectMarkers(
        cv2.cvtColor(np.pad(face, ((20, 20), (20, 20), (0, 0)), constant_values=255),
                     cv2.COLOR_RGB2GRAY))
    assert ids is not None and ids.ravel().tolist() == [tag_id]


def test_tag_geometry_matches_the_contract(make_assets):
    texture = make_assets.tag_texture(3)
    px_per_m = make_assets.PX_PER_MM * 1000
    black_rows = np.where((texture[:make_assets.FACE_PX, :make_assets.FACE_PX, 0] == 0).any(1))[0]
    assert (black_rows[-1] - black_rows[0] + 1) / px_per_m == pytest.approx(rm.TAG_SIZE)
    assert black_rows[0] / px_per_m == pytest.approx(rm.TAG_MARGIN)
    assert make_assets.FACE_PX / px_per_m == pytest.approx(rm.BLOCK_SIZE)
