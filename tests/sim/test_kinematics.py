"""The URDF's kinematics equal the UR10e's DH model, and the IK solves to spec."""

from __future__ import annotations

import math

import numpy as np
import pybullet
import pytest
from pybullet_utils import bullet_client
from ur_analytic_ik import ur10e as ur10e_ik

from nodes.common.paths import asset_path
from nodes.common.transforms import quaternion_to_matrix, tool_down_matrix
from nodes.robot import kinematics as kin
from nodes.robot import ur10e


@pytest.fixture(scope="module")
def urdf():
    client = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
    robot = client.loadURDF(str(asset_path("ur10e_2f85.urdf")), useFixedBase=True)
    joints, links = {}, {}
    for j in range(client.getNumJoints(robot)):
        info = client.getJointInfo(robot, j)
        joints[info[1].decode()] = j
        links[info[12].decode()] = j
    yield client, robot, [joints[n] for n in ur10e.ARM_JOINTS], links
    client.disconnect()


def urdf_pose(urdf, q, link: str) -> np.ndarray:
    client, robot, arm, links = urdf
    for j, v in zip(arm, q, strict=True):
        client.resetJointState(robot, j, float(v))
    state = client.getLinkState(robot, links[link], computeForwardKinematics=1)
    t = np.eye(4)
    t[:3, :3] = quaternion_to_matrix(state[4 + 1])
    t[:3, 3] = state[4]
    return t


def test_urdf_forward_kinematics_matches_dh_at_200_random_configurations(urdf):
    rng = np.random.default_rng(7)
    worst_mm, worst_deg = 0.0, 0.0
    for q in rng.uniform(-ur10e.JOINT_LIMIT, ur10e.JOINT_LIMIT, (200, 6)):
        dh = ur10e_ik.forward_kinematics(*q)
        assert np.allclose(kin.flange_pose(q), dh, atol=1e-12)  # our DH == UR's published DH
        dp, dr = kin.pose_error(urdf_pose(urdf, q, "tool0"), dh)
        worst_mm, worst_deg = max(worst_mm, dp * 1e3), max(worst_deg, math.degrees(dr))
    assert worst_mm <= 0.1 and worst_deg <= 0.01, (worst_mm, worst_deg)


def test_urdf_tcp_is_the_kinematic_tcp(urdf):
    rng = np.random.default_rng(8)
    for q in rng.uniform(-math.pi, math.pi, (20, 6)):
        dp, dr = kin.pose_error(urdf_pose(urdf, q, "tcp"), kin.tcp_pose(q))
        assert dp < 1e-4 and math.degrees(dr) < 0.01


def random_workspace_pose(rng) -> np.ndarray:
    """Gripper down (tilted up to 20 degrees) over the default workspace, up to 0.4 m high."""
    t = np.eye(4)
    tilt_axis = rng.normal(size=3) * [1, 1, 0]
    tilt_axis /= np.linalg.norm(tilt_axis)
    angle = rng.uniform(0, math.radians(20))
    k = np.array([[0, -tilt_axis[2], tilt_axis[1]], [tilt_axis[2], 0, -tilt_axis[0]],
                  [-tilt_axis[1], tilt_axis[0], 0]])
    tilt = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
    t[:3, :3] = tilt @ tool_down_matrix(rng.uniform(-math.pi, math.pi))
    t[:3, 3] = (rng.uniform(0.45, 0.95), rng.uniform(-0.35, 0.35), rng.uniform(0.005, 0.4))
    return t


def test_ik_solves_500_workspace_poses_and_agrees_with_the_urdf(urdf):
    rng = np.random.default_rng(11)
    q_ref = np.array(rm_home())
    worst = [0.0, 0.0, 0.0, 0.0]
    for _ in range(500):
        target = random_workspace_pose(rng)
        result = kin.solve_tcp_ik(target, q_ref, allow_flip=False)
        assert result.ok, result.reason
        dp, dr = kin.pose_error(kin.tcp_pose(result.q), target)
        up, ur = kin.pose_error(urdf_pose(urdf, result.q, "tcp"), target)
        worst = [max(worst[0], dp), max(worst[1], dr), max(worst[2], up), max(worst[3], ur)]
        assert np.all(np.abs(result.q) <= ur10e.JOINT_LIMIT)
        assert kin.joint_heights(result.q).min() >= kin.MIN_JOINT_HEIGHT
    assert worst[0] <= 1e-4 and math.degrees(worst[1]) <= 0.05, worst
    assert worst[2] <= 1e-4 and math.degrees(worst[3]) <= 0.05, worst


def rm_home():
    from nodes.sim.config import HOME_JOINTS

    return HOME_JOINTS


def test_home_joints_put_the_tcp_at_the_park_pose():
    from nodes.sim.config import PARK_POSITION, PARK_YAW

    t = kin.tcp_pose(rm_home())
    assert np.allclose(t[:3, 3], PARK_POSITION, atol=1e-4)
    assert math.degrees(kin.pose_error(t, _pose(PARK_POSITION, PARK_YAW))[1]) < 0.01


def _pose(position, yaw) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = tool_down_matrix(yaw)
    t[:3, 3] = position
    return t


def test_yaw_and_yaw_plus_pi_pick_the_nearer_wrist_angle():
    q_ref = np.array(rm_home())
    first = kin.solve_tcp_ik(_pose((0.7, 0.0, 0.1), 0.2), q_ref)
    flipped = kin.solve_tcp_ik(_pose((0.7, 0.0, 0.1), 0.2 + math.pi), first.q)
    assert flipped.flipped  # reached by turning the setpoint back by pi ...
    assert np.allclose(flipped.q, first.q, atol=1e-6)  # ... so the wrist does not move
    no_flip = kin.solve_tcp_ik(_pose((0.7, 0.0, 0.1), 0.2 + math.pi), first.q, allow_flip=False)
    assert abs(no_flip.q[5] - first.q[5]) == pytest.approx(math.pi, abs=1e-6)


def test_unreachable_and_below_table_poses_have_reasons():
    q_ref = np.array(rm_home())
    far = kin.solve_tcp_ik(_pose((1.6, 0.0, 0.1), 0.0), q_ref)
    assert not far.ok and "reach" in far.reason
    under = kin.solve_tcp_ik(_pose((0.3, 0.0, -0.3), 0.0), q_ref)
    assert not under.ok and under.reason
    nan = kin.solve_tcp_ik(np.full((4, 4), np.nan), q_ref)
    assert not nan.ok and "finite" in nan.reason


def test_closed_form_joint_heights_match_the_dh_chain():
    rng = np.random.default_rng(3)
    qs = rng.uniform(-ur10e.JOINT_LIMIT, ur10e.JOINT_LIMIT, (100, 6))
    chain = np.array([kin.joint_origins(q)[1:5, 2] for q in qs])
    assert np.allclose(kin.joint_heights(qs), chain, atol=1e-12)
