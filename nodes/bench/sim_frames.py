"""Perception benchmark frames rendered by the simulator's own world and camera code.

The world is the one the sim node runs, the camera the true camera of ``config/sim.yaml``
(with each lens of the benchmark in turn), the ground truth what the sim publishes on
``/sim/ground_truth`` (``SimWorld.block_poses``). Each frame's camera_info is built as the
sim publishes it (``p``: the optimal new camera matrix) and read back as the detector node
reads it, so the benchmark sees the camera through the message. A segmentation render
tells which tag squares are fully visible.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Iterator, Mapping

import cv2
import numpy as np
import pybullet

from msgs_py.camera import NO_DISTORTION, PLUMB_BOB, CameraPose
from msgs_py.ros.image import camera_info_to_camera, intrinsics_to_camera_info
from nodes.bench.perception_frames import P_EQUALS_K, RECTIFIED, Frame, LensCase, scene_for
from nodes.common.lens import rectify
from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.detector.tag_geometry import tag_corners_world
from nodes.robot.kinematics import solve_tcp_ik
from nodes.sim.camera import SimCamera, render_rgb
from nodes.sim.config import load_sim_configs
from nodes.sim.world import SimWorld

SETTLE_S = 0.25  # physics time before the first frame, s
ARM_HOVER_Z = 0.10  # TCP height over the block the arm hides, m
IN_VIEW_MARGIN_PX = 2.0


def sim_frames(seeds, density: float, noise: float | None,
               lenses: Mapping[str, LensCase] | None = None, ideal_camera: bool = False):
    """(frames iterator, true camera pose, camera description) for the given seeds: per
    seed a parked frame through every lens of ``lenses`` (default: config/sim.yaml's lens)
    and its variants, and one with the arm over the blocks through the first; with
    ``ideal_camera`` one ideal pinhole (no lens distortion, blur or noise) instead."""
    sim_config, camera_config, _ = load_sim_configs()
    if lenses is None:
        lenses = {camera_config.distortion_model: LensCase(camera_config.distortion_model,
                                                           tuple(camera_config.distortion))}
    if ideal_camera:
        camera_config = dataclasses.replace(camera_config, distortion=NO_DISTORTION,
                                            distortion_model=PLUMB_BOB, blur_sigma_px=0.0,
                                            full_well_e=0.0, noise_std=0.0)
        lenses = {"ideal": LensCase(PLUMB_BOB, NO_DISTORTION)}
    base = camera_config.model()
    noise_std = camera_config.noise_std if noise is None else noise
    true_pose = CameraPose(tuple(base.position), tuple(base.orientation_xyzw))

    def frames() -> Iterator[Frame]:
        for seed in seeds:
            world = SimWorld(dataclasses.replace(sim_config, seed=seed), base,
                             scene_for(seed, density), noise_std=noise_std)
            try:
                yield from _seed_frames(world, seed, lenses, noise_std)
            finally:
                world.close()

    c = camera_config
    shot = f"full well {c.full_well_e:g} e-" if c.full_well_e else "off"
    description = (f"blur {c.blur_sigma_px} px, shot noise {shot}, read noise {noise_std} "
                   f"grey, rectify_alpha {c.rectify_alpha}; lenses "
                   + "; ".join(f"{name}: {case.model} {list(case.d)}"
                               for name, case in lenses.items()))
    return frames(), true_pose, description


def _seed_frames(world: SimWorld, seed: int, lenses: Mapping[str, LensCase],
                 noise_std: float) -> Iterator[Frame]:
    """The seed's frames. Every lens's parked frame gets the same pixel noise (a copy of the
    world's generator), so the lens rows differ by the lens alone; the first lens's frames
    draw it as the sim node would (``SimWorld.render``: parked, then arm over blocks)."""
    world.step(max(1, round(SETTLE_S / world.config.dt)))
    truth = {b.id: b for b in world.block_poses()}
    start = copy.deepcopy(world.rng)
    first = None
    for name, case in lenses.items():
        camera = dataclasses.replace(world.camera, distortion=case.d,
                                     distortion_model=case.model)
        rng = copy.deepcopy(start)
        image = render_rgb(world.client, camera, noise_std, rng)
        visible = fully_visible_tags(world, camera, truth)
        yield _frame("parked", name, image, camera, truth, visible)
        for variant in case.variants:
            yield _variant_frame(name, variant, image, camera, truth, visible)
        first = first or (name, image, camera, rng)
    name, parked, camera, rng = first
    if arm_over_a_block(world, truth, np.random.default_rng(seed)):
        image = render_rgb(world.client, camera, noise_std, rng)
        visible = fully_visible_tags(world, camera, truth)
        frame = _frame("arm over blocks", name, image, camera, truth, visible)
        yield dataclasses.replace(frame, warmup=parked)


def _frame(situation: str, lens: str, image: np.ndarray, camera: SimCamera, truth,
           visible: set[int], p_equals_k: bool = False, rectified: bool = False) -> Frame:
    """A frame with its camera as the detector node would read it from camera_info."""
    info = intrinsics_to_camera_info(camera.intrinsics, 0,
                                     rectified=None if p_equals_k else camera.rectified)
    return Frame(situation, image, camera_info_to_camera(info, rectified), truth, visible,
                 set(truth) - visible, lens=lens)


def _variant_frame(lens: str, variant: str, image: np.ndarray, camera: SimCamera, truth,
                   visible: set[int]) -> Frame:
    """The same frame as camera_info with p = k describes it, or rectified as image_proc
    publishes it (bilinear, into p's camera) for a detector with ``image_rectified``."""
    name = f"{lens}, {variant}"
    if variant == P_EQUALS_K:
        return _frame("parked", name, image, camera, truth, visible, p_equals_k=True)
    if variant != RECTIFIED:
        raise ValueError(f"unknown lens variant '{variant}'")
    rect = camera.rectified
    in_rect = {i for i in visible if _inside(rect, camera, truth[i])}
    return _frame("parked", name, rectify(image, camera.intrinsics, rect), camera, truth,
                  in_rect, rectified=True)


def _inside(rect, camera: SimCamera, block) -> bool:
    """Whether the tag's corners lie in the rectified image (it crops the raw one)."""
    ideal = camera.project_ideal(tag_corners_world(block))
    uv = (ideal - [camera.cx, camera.cy]) / [camera.fx, camera.fy] * [rect.fx, rect.fy] + [
        rect.cx, rect.cy]
    m = IN_VIEW_MARGIN_PX
    return bool(np.all((uv >= m) & (uv <= [rect.width - 1 - m, rect.height - 1 - m])))


def arm_over_a_block(world: SimWorld, truth, rng: np.random.Generator,
                     hover_z: float = ARM_HOVER_Z) -> bool:
    """Put the arm's TCP ``hover_z`` over a random block (joints set, no motion); False if
    the IK finds no way there."""
    target = truth[int(rng.choice(sorted(truth)))]
    ik = solve_tcp_ik(pose_matrix([target.x, target.y, hover_z],
                                  tool_down_quaternion(target.theta)), world.arm_q())
    if not ik.ok:
        return False
    for joint, q in zip(world.arm_joints, ik.q, strict=True):
        world.client.resetJointState(world.robot, joint, float(q), 0.0)
    return True


def fully_visible_tags(world: SimWorld, camera: SimCamera, truth) -> set[int]:
    """Ids whose whole tag square is the block's own pixels in a segmentation render (a
    pinhole render: the square is looked up where the pinhole images it) and whose corners
    the lens images inside the frame."""
    _, _, _, _, seg = world.client.getCameraImage(
        camera.width, camera.height, camera.view_matrix(), camera.projection_matrix(),
        renderer=pybullet.ER_TINY_RENDERER, shadow=0)
    seg = np.asarray(seg).reshape(camera.height, camera.width)
    visible = set()
    for block_id, block in truth.items():
        corners = camera.project_ideal(tag_corners_world(block))
        if not np.all(np.isfinite(corners)):
            continue
        mask = np.zeros(seg.shape, np.uint8)
        cv2.fillConvexPoly(mask, np.rint(corners).astype(np.int32), 1)
        mask = cv2.erode(mask, np.ones((3, 3), np.uint8))
        inside = mask.astype(bool)
        in_view = np.all(camera.sees(tag_corners_world(block), margin_px=IN_VIEW_MARGIN_PX))
        if in_view and inside.any() and np.all(seg[inside] == world.block_bodies[block_id]):
            visible.add(block_id)
    return visible
