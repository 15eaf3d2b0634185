"""The sim node's parameters (frozen dataclasses; names, defaults, units as in config/sim.yaml)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from msgs_py.camera import (
    CAMERA_RELIABILITIES,
    DISTORTION_COEFFICIENTS,
    coefficients_reason,
)
from nodes.common.params import configs_from_parameters, param, read_params_file
from nodes.common.paths import config_path
from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e
from nodes.sim.camera import DEFAULT_LENS_MODEL, LENS_COEFFICIENTS, SimCamera
from nodes.sim.joint_control import MOTION_CONTROLLERS

#: Park pose of the TCP (world, tool pointing down, closing axis along x): outside the camera's
#: view of the workspace; the executor parks here before asking for a fresh detection.
PARK_POSITION = (0.25, -0.55, 0.40)
PARK_YAW = 0.0
#: ``PARK_POSITION`` solved on the elbow-up, wrist-down branch the workspace is reached on.
HOME_JOINTS = ur10e.WORKING_BRANCH_JOINTS


@dataclass(frozen=True)
class SimConfig:
    scene_file: str = param("scenes/default.yaml",
                            "scene file (msgs_py scene; relative paths resolve under config/); "
                            "ignored when random.n_blocks > 0")
    physics_rate_hz: float = param(240.0, "physics step rate (>= 240)", unit="Hz")
    solver_iterations: int = param(100, "constraint solver iterations per physics step")
    real_time_factor: float = param(
        1.0, "pacing floor: simulated time never runs slower than this many seconds per wall "
        "second (0 = no floor)")
    lockstep_margin_s: float = param(
        0.03, "while motion commands come, the sim runs as fast as it can but stays this far "
        "(simulated time) behind the end of the newest one's motion (a trajectory's first point "
        "of the position it then holds, which the arm node keeps within its horizon of the "
        "executor's newest setpoint), and waits "
        "there while that command moves the arm, so it never outruns the nodes that command "
        "it; 0 = pace by real_time_factor alone", unit="s")
    motion_controller: str = param(
        "scaled_joint_trajectory_controller", "the active motion controller, as "
        "ur_robot_driver's initial_joint_controller: scaled_joint_trajectory_controller "
        "(JointTrajectory) or forward_position_controller (Float64MultiArray)")
    speed_slider: float = param(
        1.0, "the teach pendant's speed slider at start (fraction 0-1; /sim/speed_slider "
        "changes it; the driver reports it in percent)")
    protective_stop_unlock_after_s: float = param(
        5.0, "the dashboard refuses to unlock a protective stop sooner than this after it, as "
        "a UR does", unit="s")
    clock_rate_hz: float = param(100.0, "/clock publish rate in simulated time", unit="Hz")
    state_rate_hz: float = param(
        50.0, "rate of the drivers' joint states (/joint_states, /gripper/joint_states) in "
        "simulated time", unit="Hz")
    status_rate_hz: float = param(
        10.0, "rate of the UR driver's TCP pose and speed scaling broadcasters in simulated "
        "time (the driver's controllers file sets theirs; no densepack node needs them fast: "
        "the arm node computes the TCP from the joint states)", unit="Hz")
    ground_truth_rate_hz: float = param(
        10.0, "/sim/ground_truth rate in simulated time", unit="Hz")
    events_rate_hz: float = param(2.0, "/sim/events rate in simulated time", unit="Hz")
    contact_check_rate_hz: float = param(
        60.0, "how often the event monitor inspects contacts (simulated time)", unit="Hz")
    grip_force: float = param(g85.GRIP_FORCE_DEFAULT, "finger force limit (2F-85: 20-235 N)",
                              unit="N")
    gripper_speed: float = param(g85.CLOSING_SPEED_DEFAULT,
                                 "gap closing/opening speed (2F-85: 0.02-0.15 m/s)", unit="m/s")
    tool_force_limit: float = param(
        20.0, "the arm stops (a protective stop) when the force on the robot from blocks and "
        "table exceeds this; it moves again once the dashboard's unlock_protective_stop and "
        "play have been called (0 = off)", unit="N")
    home_joints: tuple = param(list(HOME_JOINTS), "arm joints at start and after /sim/reset "
                               "(the park pose)", unit="rad")
    park_position: tuple = param(list(PARK_POSITION), "park TCP position for the executor "
                                 "(tool down; informational)", unit="m")
    lost_margin: float = param(0.02, "a resting block whose centre is this far outside the "
                               "workspace counts as lost", unit="m")
    seed: int = param(0, "seed of the cell's randomness (pixel noise, block-to-block spread)")
    block_mass_spread: float = param(
        0.08, "relative standard deviation of the blocks' masses (softwood density varies "
        "400-550 kg/m^3)")
    block_friction_spread: float = param(
        0.15, "relative standard deviation of the blocks' friction coefficients (wood on wood "
        "or MDF: 0.25-0.5)")
    gripper_latency_s: float = param(
        0.02, "time from a knuckle command to the gripper acting on it (2F-85 on Modbus RTU: "
        "a request/response cycle of a few ms plus the driver's polling)", unit="s")
    start_paused: bool = param(
        False, "hold the clock at 0 until /sim/start is called: a launcher that starts the "
        "cell's processes calls it once they are up, so no simulated time passes while they "
        "start (the state topics go on, stamped 0)")
    reset_scene_only: bool = param(
        False, "what /sim/reset does: true lays out a new scene (scene_file and random.* as "
        "they are at the call) and clears the events, leaving the clock, the arm, the fingers "
        "and the robot's state as they are (for a running cell, whose nodes run on this clock); "
        "false also puts the arm home, opens the fingers and starts the clock again at 0")

    def __post_init__(self) -> None:
        if self.tool_force_limit < 0.0:
            raise ValueError(f"tool_force_limit must be >= 0, got {self.tool_force_limit}")
        if self.physics_rate_hz < 240.0:
            raise ValueError(f"physics_rate_hz must be >= 240, got {self.physics_rate_hz}")
        if self.real_time_factor < 0.0:
            raise ValueError(f"real_time_factor must be >= 0, got {self.real_time_factor}")
        if self.lockstep_margin_s < 0.0:
            raise ValueError(f"lockstep_margin_s must be >= 0, got {self.lockstep_margin_s}")
        if self.motion_controller not in MOTION_CONTROLLERS:
            raise ValueError(f"motion_controller must be one of {list(MOTION_CONTROLLERS)}, "
                             f"got '{self.motion_controller}'")
        if not 0.0 <= self.speed_slider <= 1.0:
            raise ValueError(f"speed_slider must be in [0, 1], got {self.speed_slider}")
        if self.protective_stop_unlock_after_s < 0.0:
            raise ValueError("protective_stop_unlock_after_s must be >= 0")
        for name in ("clock_rate_hz", "state_rate_hz", "status_rate_hz",
                     "ground_truth_rate_hz", "events_rate_hz", "contact_check_rate_hz"):
            if getattr(self, name) <= 0.0:
                raise ValueError(f"{name} must be > 0")
        lo, hi = g85.GRIP_FORCE_RANGE
        if not lo <= self.grip_force <= hi:
            raise ValueError(f"grip_force must be in [{lo}, {hi}] N, got {self.grip_force}")
        lo, hi = g85.CLOSING_SPEED_RANGE
        if not lo <= self.gripper_speed <= hi:
            raise ValueError(f"gripper_speed must be in [{lo}, {hi}] m/s")
        if len(self.home_joints) != 6 or not all(math.isfinite(v) for v in self.home_joints):
            raise ValueError(f"home_joints needs 6 finite values, got {self.home_joints}")
        if len(self.park_position) != 3:
            raise ValueError("park_position needs 3 values")
        if not 0.0 <= self.block_mass_spread < 0.5 or not 0.0 <= self.block_friction_spread < 0.5:
            raise ValueError("block_mass_spread and block_friction_spread must be in [0, 0.5)")
        if self.gripper_latency_s < 0.0:
            raise ValueError(f"gripper_latency_s must be >= 0, got {self.gripper_latency_s}")

    @property
    def dt(self) -> float:
        return 1.0 / self.physics_rate_hz


@dataclass(frozen=True)
class CameraConfig:
    """The TRUE camera (the detector never reads it; it has config/camera_calibration.yaml)."""

    width: int = param(1280, "image width", unit="px")
    height: int = param(960, "image height", unit="px")
    fx: float = param(1400.0, "focal length x", unit="px")
    fy: float = param(1400.0, "focal length y", unit="px")
    cx: float = param(639.5, "principal point x", unit="px")
    cy: float = param(479.5, "principal point y", unit="px")
    position: tuple = param([0.7042, -0.0031, 1.2468],
                            "camera_optical_frame origin in world (true pose)", unit="m")
    orientation_xyzw: tuple = param(
        [0.7095437, -0.7046074, -0.0086431, 0.001204],
        "camera_optical_frame orientation in world (true pose; x y z w)")
    rate_hz: float = param(2.0, "image rate in simulated time (0 = only on /sim/render_request)",
                           unit="Hz")
    noise_std: float = param(0.23, "std of the signal-independent (read) pixel noise; 0 = "
                             "none", unit="grey levels")
    full_well_e: float = param(10000.0, "electrons at full scale (255): photon shot noise of "
                               "variance grey x 255 / full_well_e; 0 = none", unit="e-")
    blur_sigma_px: float = param(0.5, "sigma of the Gaussian blur (lens, diffraction, pixel "
                                 "area); 0 = none", unit="px")
    distortion_model: str = param(
        DEFAULT_LENS_MODEL, "lens model of camera.distortion, as camera_info names it: plumb_bob "
        "(k1 k2 p1 p2 k3), rational_polynomial (k1 k2 p1 p2 k3 k4 k5 k6) or equidistant "
        "(fisheye: k1 k2 k3 k4)")
    distortion: tuple = param(list(LENS_COEFFICIENTS[DEFAULT_LENS_MODEL]),
                              "lens distortion coefficients of camera.distortion_model, "
                              "OpenCV's order (published in camera_info d); all zero = ideal "
                              "pinhole")
    rectify_alpha: float = param(
        0.0, "camera_info p is OpenCV's optimal new camera matrix of k and d at this alpha "
        "(0: every rectified pixel shows the scene, ROS camera_calibration's default; 1: "
        "every raw pixel is kept)")
    reliability: str = param(
        "reliable", "QoS reliability of the /camera/* publishers: reliable (a subscriber of "
        "either kind hears it) or best_effort (a camera driver's sensor-data QoS: only "
        "best-effort subscribers hear it)")

    def __post_init__(self) -> None:
        if len(self.position) != 3 or len(self.orientation_xyzw) != 4:
            raise ValueError("camera.position needs 3 values, camera.orientation_xyzw 4")
        if self.rate_hz < 0 or self.noise_std < 0:
            raise ValueError("camera.rate_hz and camera.noise_std must be >= 0")
        if self.full_well_e < 0 or self.blur_sigma_px < 0:
            raise ValueError("camera.full_well_e and camera.blur_sigma_px must be >= 0")
        if self.distortion_model not in DISTORTION_COEFFICIENTS:
            raise ValueError(f"camera.distortion_model: '{self.distortion_model}' is not one "
                             f"of {sorted(DISTORTION_COEFFICIENTS)}")
        if len(self.distortion) != len(DISTORTION_COEFFICIENTS[self.distortion_model]):
            raise ValueError(f"camera.distortion: {coefficients_reason(self.distortion_model)},"
                             f" got {len(self.distortion)} values")
        if self.reliability not in CAMERA_RELIABILITIES:
            raise ValueError(f"camera.reliability: '{self.reliability}' is not one of "
                             f"{list(CAMERA_RELIABILITIES)}")
        self.model()  # a distortion that folds the image over, a bad alpha: fail at startup

    def model(self) -> SimCamera:
        return SimCamera(self.width, self.height, self.fx, self.fy, self.cx, self.cy,
                         tuple(self.position), tuple(self.orientation_xyzw),
                         distortion=tuple(self.distortion), blur_sigma_px=self.blur_sigma_px,
                         full_well_e=self.full_well_e, distortion_model=self.distortion_model,
                         rectify_alpha=self.rectify_alpha)


@dataclass(frozen=True)
class RandomSceneConfig:
    n_blocks: int = param(0, "random scene with this many blocks (0 = use scene_file)")
    density: float = param(0.25, "random scene density: block area / workspace area")
    seed: int = param(0, "random scene seed")


#: The sim node's parameter groups, as ``--params-file`` names them.
SIM_PARAMETERS = (("", SimConfig), ("camera.", CameraConfig), ("random.", RandomSceneConfig))


def load_sim_configs(path: str | Path | None = None
                     ) -> tuple[SimConfig, CameraConfig, RandomSceneConfig]:
    """The sim's configs from its parameter file (default ``config/sim.yaml``), as the node
    would declare them: for tools and tests that build a ``SimWorld`` without ROS.

    Raises:
        ValueError: an unknown parameter or a bad value (named with the file).
    """
    file = config_path(path or "sim.yaml")
    values = read_params_file(file, node_name="sim")
    sim, camera, random = configs_from_parameters(SIM_PARAMETERS, values, str(file))
    return sim, camera, random
