"""Benchmark frames rendered by the simulator's own world and camera code.

Kept apart from ``bench`` because it imports the sim (PyBullet): the world is the one the
sim node runs, the camera is the true camera of ``config/sim.yaml``, the ground truth is
what the sim publishes on ``/sim/ground_truth`` (``SimWorld.block_poses``). A segmentation
render tells which tag squares are fully visible.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import cv2
import numpy as np
import pybullet

from msgs_py.camera import CameraPose
from nodes.common.transforms import tool_down_quaternion
from nodes.detector.bench import Frame, scene_for
from nodes.detector.tag_geometry import tag_corners_world

SETTLE_S = 0.25  # physics time before the first frame, s
ARM_HOVER_Z = 0.10  # TCP height over the block the arm hides, m


def sim_frames(seeds, density: float, noise: float | None, ideal_camera: bool = False):
    """(frames iterator, true camera pose, camera description) for the given seeds; the
    camera of config/sim.yaml, or with ``ideal_camera`` the same one as an ideal pinhole
    (no lens distortion, blur or noise)."""
    from nodes.common.transforms import pose_matrix
    from nodes.robot.kinematics import solve_tcp_ik
    from nodes.sim.config import load_sim_configs
    from nodes.sim.world import SimWorld

    sim_config, camera_config, _ = load_sim_configs()
    if ideal_camera:
        camera_config = dataclasses.replace(camera_config, distortion=(0.0,) * 5,
                                            blur_sigma_px=0.0, full_well_e=0.0, noise_std=0.0)
    camera = camera_config.model()
    noise_std = camera_config.noise_std if noise is None else noise
    intrinsics = camera.intrinsics
    true_pose = CameraPose(tuple(camera.position), tuple(camera.orientation_xyzw))

    def frames() -> Iterator[Frame]:
        for seed in seeds:
            scene = scene_for(seed, density)
            world = SimWorld(dataclasses.replace(sim_config, seed=seed), camera, scene,
                             noise_std=noise_std)
            try:
                world.step(max(1, round(SETTLE_S / sim_config.dt)))
                truth = {b.id: b for b in world.block_poses()}
                parked = world.render()
                visible = _fully_visible(world, camera, truth)
                yield Frame("parked", parked, intrinsics, truth, visible,
                            set(truth) - visible)
                rng = np.random.default_rng(seed)
                target = truth[int(rng.choice(sorted(truth)))]
                ik = solve_tcp_ik(pose_matrix([target.x, target.y, ARM_HOVER_Z],
                                              tool_down_quaternion(target.theta)),
                                  world.arm_q())
                if not ik.ok:
                    continue
                for joint, q in zip(world.arm_joints, ik.q, strict=True):
                    world.client.resetJointState(world.robot, joint, float(q), 0.0)
                image = world.render()
                visible = _fully_visible(world, camera, truth)
                yield Frame("arm over blocks", image, intrinsics, truth, visible,
                            set(truth) - visible, warmup=parked)
            finally:
                world.close()

    c = camera_config
    shot = f"full well {c.full_well_e:g} e-" if c.full_well_e else "off"
    description = (f"d {list(c.distortion)}, blur {c.blur_sigma_px} px, shot noise {shot}, "
                   f"read noise {noise_std} grey")
    return frames(), true_pose, description


def _fully_visible(world, camera, truth) -> set[int]:
    """Ids whose whole tag square is the block's own pixels in a segmentation render."""
    _, _, _, _, seg = world.client.getCameraImage(
        camera.width, camera.height, camera.view_matrix(), camera.projection_matrix(),
        renderer=pybullet.ER_TINY_RENDERER, shadow=0)
    seg = np.asarray(seg).reshape(camera.height, camera.width)
    visible = set()
    for block_id, block in truth.items():
        corners = camera.project(tag_corners_world(block))
        if not np.all(np.isfinite(corners)):
            continue
        mask = np.zeros(seg.shape, np.uint8)
        cv2.fillConvexPoly(mask, np.rint(corners).astype(np.int32), 1)
        mask = cv2.erode(mask, np.ones((3, 3), np.uint8))
        inside = mask.astype(bool)
        in_view = np.all(camera.sees(tag_corners_world(block), margin_px=2.0))
        if in_view and inside.any() and np.all(seg[inside] == world.block_bodies[block_id]):
            visible.add(block_id)
    return visible
