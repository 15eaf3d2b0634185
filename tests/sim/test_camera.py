"""The overhead camera: tags land on the pixels the intrinsics and the lens (every model)
predict, all are visible; camera_info carries the lens and p; blur and noise are the
configured ones, and seeded."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from msgs_py import load_scene
from msgs_py.ros.image import intrinsics_to_camera_info
from nodes.bench.perception_frames import LENSES
from nodes.common.paths import config_path
from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.detector.tags import TagFinder
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik
from nodes.sim import robot_model as rm
from nodes.sim.camera import canvas_camera, render_pinhole, render_rgb
from nodes.sim.config import CameraConfig, SimConfig
from nodes.sim.world import SimWorld
from tests.unit.detector.lenses import MODELS, sim_camera


def detect(rgb: np.ndarray) -> dict[int, np.ndarray]:
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    corners, ids, _ = cv2.aruco.ArucoDetector(dictionary, params).detectMarkers(
        cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))
    return {} if ids is None else {int(i): c[0] for i, c in zip(ids.ravel(), corners, strict=True)}


@pytest.fixture(scope="module")
def default_world():
    world = SimWorld(SimConfig(), CameraConfig().model(),
                     load_scene(config_path("scenes/default.yaml")))
    world.step(24)
    yield world
    world.close()


def tag_corners_world(world: SimWorld, block_id: int) -> np.ndarray:
    """The tag's corners in OpenCV order (docs/contracts.md), in world."""
    pos, quat = world.block_pose_3d(block_id)
    rot = np.asarray(world.client.getMatrixFromQuaternion(quat)).reshape(3, 3)
    h, top = rm.TAG_SIZE / 2, rm.BLOCK_SIZE / 2
    local = np.array([[-h, h, top], [h, h, top], [h, -h, top], [-h, -h, top]])
    return pos + local @ rot.T


def test_every_tag_is_seen_with_the_arm_at_home(default_world):
    seen = detect(default_world.render())
    assert sorted(seen) == sorted(default_world.block_bodies)


def test_tag_centres_and_corners_land_on_the_predicted_pixels(default_world):
    seen = detect(default_world.render())
    centre_errors = []
    for block_id, corners_px in seen.items():
        predicted = default_world.camera.project(tag_corners_world(default_world, block_id))
        # corner order and orientation follow the contract ...
        assert np.max(np.linalg.norm(corners_px - predicted, axis=1)) < 2.0
        # ... and the centre is on the predicted pixel
        centre_errors.append(np.linalg.norm(corners_px.mean(0) - predicted.mean(0)))
    assert max(centre_errors) <= 1.0, centre_errors


def test_a_tag_is_at_least_30_px_across_over_the_whole_workspace():
    camera = CameraConfig().model()
    ws = load_scene(config_path("scenes/default.yaml")).workspace
    for x in (ws.x_min, ws.x_max):
        for y in (ws.y_min, ws.y_max):
            corners = np.array([[x - 0.02, y, rm.BLOCK_SIZE], [x + 0.02, y, rm.BLOCK_SIZE]])
            uv = camera.project(corners)
            assert np.linalg.norm(uv[0] - uv[1]) >= 30.0


@pytest.mark.parametrize("model", MODELS)
def test_the_lens_images_tags_where_opencv_projects_them(model):
    """The warp's direction, for every lens model: tag corners measured on the rendered
    (distorted) image are where OpenCV's projection (cv2.projectPoints, or cv2.fisheye's for
    equidistant) puts the blocks' true corners with the published ``d``, and far from where
    a pinhole would put them."""
    camera = sim_camera(model)
    assert camera.intrinsics.distorted and camera.distortion_model == model
    world = SimWorld(SimConfig(), camera, load_scene(config_path("scenes/calibration.yaml")))
    try:
        world.step(24)
        image = render_rgb(world.client, camera)  # the configured blur and shot noise
        found = {d.tag_id: d.corners for d in TagFinder().find(image[..., 1])}
        assert sorted(found) == sorted(world.block_bodies)
        errors, pinhole_errors = [], []
        for block_id, corners in found.items():
            truth = tag_corners_world(world, block_id)
            errors += list(np.linalg.norm(corners - opencv_projection(camera, truth), axis=1))
            pinhole_errors += list(np.linalg.norm(corners - camera.project_ideal(truth),
                                                  axis=1))
    finally:
        world.close()
    assert np.median(errors) < 0.15 and np.max(errors) < 0.6, (np.median(errors),
                                                                np.max(errors))
    assert np.max(pinhole_errors) > 4.0  # the lens matters at the edges of the view


def opencv_projection(camera, points_world: np.ndarray) -> np.ndarray:
    """OpenCV's projection of world points through the camera's lens (the reference)."""
    r_wc = camera.rotation
    rvec, _ = cv2.Rodrigues(r_wc.T)
    tvec = -r_wc.T @ np.asarray(camera.position)
    d = np.asarray(camera.distortion)
    if camera.distortion_model == "equidistant":
        out, _ = cv2.fisheye.projectPoints(points_world.reshape(-1, 1, 3), rvec, tvec,
                                           camera.k, d)
    else:
        out, _ = cv2.projectPoints(points_world, rvec, tvec, camera.k, d)
    return out.reshape(-1, 2)


def test_camera_info_carries_the_lens_and_p_apart_from_k():
    """What the sim publishes: k, the model's d and its name, p = the optimal new camera
    matrix: not k, and at alpha 1 (every raw pixel kept) a wider view than at alpha 0."""
    for model in MODELS:
        camera = sim_camera(model)
        info = intrinsics_to_camera_info(camera.intrinsics, 0, rectified=camera.rectified)
        assert info.distortion_model == model and len(info.d) == len(LENSES[model].d)
        assert abs(info.p[0] - info.k[0]) > 10.0 and abs(info.p[5] - info.k[4]) > 10.0
    wide = sim_camera("plumb_bob", rectify_alpha=1.0)
    assert wide.rectified.fx < CameraConfig().model().rectified.fx


@pytest.mark.parametrize("overrides,named", [
    ({"distortion_model": "plumb_bob"}, "5 coefficients"),  # the default d has 8
    ({"distortion_model": "kannala_brandt"}, "distortion_model"),
    ({"distortion_model": "plumb_bob", "distortion": [-0.9, 0.0, 0.0, 0.0, 0.0]}, "folds over"),
    ({"rectify_alpha": 1.5}, "rectify_alpha"),
    ({"reliability": "sometimes"}, "reliability"),
])
def test_a_bad_lens_or_qos_is_refused_naming_it(overrides, named):
    with pytest.raises(ValueError, match=named):
        CameraConfig(**overrides)


def test_pixel_noise_is_the_configured_shot_and_read_noise_and_seeded(default_world):
    """Grey-level noise std: sqrt(read^2 + grey x 255 / full_well), per pixel; the same seed
    gives the same frame."""
    camera = dataclasses.replace(default_world.camera, full_well_e=10000.0)
    blurred_only = dataclasses.replace(camera, full_well_e=0.0)
    clean = render_rgb(default_world.client, blurred_only).astype(float)
    noisy = render_rgb(default_world.client, camera, 0.5,
                       np.random.default_rng(3)).astype(float)
    again = render_rgb(default_world.client, camera, 0.5, np.random.default_rng(3))
    assert np.array_equal(again, noisy.astype(np.uint8))
    for lo, hi in ((20.0, 60.0), (150.0, 240.0)):
        mask = (clean >= lo) & (clean < hi)
        expected = np.sqrt(0.5**2 + np.mean(clean[mask]) * 255.0 / 10000.0 + 1.0 / 12.0)
        assert np.std((noisy - clean)[mask]) == pytest.approx(expected, rel=0.1)


def test_camera_config_defaults_frame_the_default_workspace():
    camera = CameraConfig().model()
    assert camera.width == 1280 and camera.height == 960
    footprint = camera.ground_footprint(0.0)
    # long image side along world y, image "up" (row 0) towards +x
    assert np.ptp(footprint[:, 1]) > np.ptp(footprint[:, 0])
    assert footprint[0, 0] > footprint[3, 0]


@pytest.mark.parametrize("y", [-0.35, 0.0, 0.35])
def test_the_look_pose_hides_no_block_from_the_camera(y):
    """The executor's look pose (x_min - look_offset, at look_height): blocks along the
    workspace's robot-side edge and everywhere else keep their whole tag in view."""
    from msgs_py import BlockPose, Scene, Workspace
    from nodes.common.transforms import pose_matrix, tool_down_quaternion
    from nodes.executor.config import ExecutorConfig
    from nodes.executor.motion import ToolPose
    from nodes.executor.primitives import look_pose
    from nodes.robot.kinematics import solve_tcp_ik

    ws = Workspace(0.45, 0.95, -0.35, 0.35)
    s = rm.BLOCK_SIZE
    spots = [(x, yy) for x in (ws.x_min + s / 2 + 0.002, 0.62, 0.80)
             for yy in np.linspace(ws.y_min + s / 2 + 0.002, ws.y_max - s / 2 - 0.002, 5)]
    scene = Scene(ws, s, tuple(BlockPose(k, x, yy, 0.0) for k, (x, yy) in enumerate(spots)))
    world = SimWorld(SimConfig(), CameraConfig().model(), scene)
    try:
        cfg = ExecutorConfig()
        look = look_pose(cfg, ws, ToolPose(0.7, y, cfg.travel_height, 0.0))
        ik = solve_tcp_ik(pose_matrix([look.x, look.y, look.z], tool_down_quaternion(look.yaw)),
                          world.arm_q())
        assert ik.ok, ik.reason
        for joint, q in zip(world.arm_joints, ik.q, strict=True):
            world.client.resetJointState(world.robot, joint, float(q), 0.0)
        world.step(2)
        seen = detect(world.render())
        assert sorted(seen) == list(range(len(spots)))
    finally:
        world.close()


def test_the_table_painted_in_gives_the_pixels_of_the_table_rasterised():
    """A frame renders without the table (its rasterisation took most of the frame's time)
    and paints its one colour where nothing else is: the same pixels, with the arm reaching
    low over the blocks, through a lens."""
    camera = sim_camera("rational_polynomial")
    world = SimWorld(SimConfig(), camera, load_scene(config_path("scenes/default.yaml")))
    try:
        assert world.backdrop is not None and world.backdrop.body == world.table
        over = solve_tcp_ik(pose_matrix((0.70, 0.05, 0.12), tool_down_quaternion(0.3)),
                            np.asarray(ur10e.WORKING_BRANCH_JOINTS, float)).q
        for joint, q in zip(world.arm_joints, over, strict=True):
            world.client.resetJointState(world.robot, joint, float(q))
        view = canvas_camera(camera)
        painted, _ = render_pinhole(world.client, view, world.backdrop)
        rasterised, _ = render_pinhole(world.client, view)
        assert np.array_equal(painted, rasterised)
        assert (painted == world.backdrop.rgb).all(axis=-1).mean() > 0.5  # the table is there
    finally:
        world.close()


def test_no_backdrop_where_the_table_does_not_fill_the_view():
    """A camera that sees past the table's edge renders the table as it is."""
    camera = dataclasses.replace(CameraConfig().model(), position=(0.7, 0.0, 6.0))
    world = SimWorld(SimConfig(), camera, load_scene(config_path("scenes/default.yaml")))
    try:
        assert world.backdrop is None
    finally:
        world.close()
