"""The sim's stand-ins for ur_robot_driver's motion controllers: what they accept, refuse and
play."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodes.robot import ur10e
from nodes.sim.joint_control import (
    ForwardPositionController,
    TrajectoryController,
    check_trajectory,
    hermite,
)

JOINTS = ur10e.ARM_JOINTS
Q0 = np.array([0.1, -1.2, 1.4, 1.3, 1.57, 0.2])


def point(t, q, v=(), a=(), effort=()):
    return (t, list(q), list(v), list(a), list(effort))


def test_a_good_trajectory_in_any_joint_order_is_accepted_and_reordered():
    names = list(reversed(JOINTS))
    target = Q0 + 0.1
    ctrl = TrajectoryController(Q0)
    assert ctrl.receive(names, 0.0, [point(0.5, target[::-1], [0.0] * 6)], now=1.0) == ""
    t, dt = 1.0, 1 / 240
    for _ in range(121):  # the trajectory ends 0.5 s after its first sample
        q, _ = ctrl.update(t, dt, 1.0, Q0, np.zeros(6))
        t += dt
    assert np.allclose(q, target, atol=1e-9)


@pytest.mark.parametrize(("names", "points", "words"), [
    (JOINTS[:5], [point(0.1, Q0[:5])], "don't match the controller joints"),
    ((*JOINTS[:5], "gripper_joint"), [point(0.1, Q0)], "Incoming joint gripper_joint"),
    (JOINTS, [], "Empty trajectory"),
    (JOINTS, [point(0.1, Q0, [0.1] * 6)], "is not zero"),
    (JOINTS, [point(0.2, Q0), point(0.1, Q0)], "not strictly increasing"),
    (JOINTS, [point(0.1, Q0[:4])], "positions"),
    (JOINTS, [point(0.1, [*Q0[:5], math.nan])], "non-finite"),
    (JOINTS, [point(0.1, [*Q0[:5], 7.0])], "past its limit"),
    (JOINTS, [point(0.1, Q0, effort=[1.0] * 6)], "effort"),
])
def test_bad_trajectories_are_refused_with_the_controllers_reason(names, points, words):
    ctrl = TrajectoryController(Q0)
    error = ctrl.receive(names, 0.0, points, now=0.0)
    assert words in error
    assert not ctrl.active  # nothing of it kept: the arm holds
    q, _ = ctrl.update(0.01, 0.01, 1.0, Q0, np.zeros(6))
    assert np.allclose(q, Q0)


def test_a_stamped_trajectory_that_ends_in_the_past_is_refused():
    assert "ends in the past" in check_trajectory(JOINTS, JOINTS, 5.0, [point(0.1, Q0)], now=6.0)
    assert check_trajectory(JOINTS, JOINTS, 5.0, [point(2.0, Q0)], now=6.0) == ""


def test_a_new_trajectory_replaces_the_old_one_from_where_the_arm_is():
    ctrl = TrajectoryController(Q0)
    far = Q0 + 0.5
    ctrl.receive(JOINTS, 0.0, [point(1.0, far, [0.0] * 6)], now=0.0)
    t, dt = 0.0, 1 / 240
    for _ in range(60):  # a quarter second towards `far`
        t += dt
        q, _ = ctrl.update(t, dt, 1.0, Q0, np.zeros(6))
    halfway = q.copy()
    assert np.all(halfway > Q0) and np.all(halfway < far)
    back = Q0 - 0.2
    ctrl.receive(JOINTS, 0.0, [point(0.5, back, [0.0] * 6)], now=t)
    for _ in range(240):
        t += dt
        q, _ = ctrl.update(t, dt, 1.0, halfway, np.zeros(6))
    assert np.allclose(q, back)  # `far` forgotten


def test_speed_scaling_slows_the_trajectory_clock():
    def position_after(scaling: float, seconds: float) -> np.ndarray:
        ctrl = TrajectoryController(Q0)
        ctrl.receive(JOINTS, 0.0, [point(1.0, Q0 + 1.0, [0.0] * 6)], now=0.0)
        t, dt, q = 0.0, 1 / 240, Q0
        for _ in range(round(seconds / dt)):
            t += dt
            q, _ = ctrl.update(t, dt, scaling, Q0, np.zeros(6))
        return q

    full, half, still = position_after(1.0, 0.5), position_after(0.5, 0.5), position_after(0.0,
                                                                                           0.5)
    assert np.all(full > half) and np.all(half > Q0)
    assert np.allclose(still, Q0)  # the slider at 0: the arm waits on its path
    assert np.allclose(position_after(0.5, 2.1), Q0 + 1.0)  # late, but it gets there


def test_cubic_and_quintic_splines_meet_their_end_conditions():
    q0, q1 = np.array([0.0]), np.array([1.0])
    v0, v1, zero = np.array([0.5]), np.array([-0.2]), np.zeros(1)
    for quintic in (False, True):
        qa, va = hermite(0.0, 0.0, 2.0, q0, v0, zero, q1, v1, zero, quintic)
        qb, vb = hermite(2.0, 0.0, 2.0, q0, v0, zero, q1, v1, zero, quintic)
        assert np.allclose([qa, va, qb, vb], [q0, v0, q1, v1])


def test_forward_position_commands_are_checked_and_held_within_velocity_limits():
    ctrl = ForwardPositionController(Q0)
    assert "does not match number of interfaces" in ctrl.receive(Q0[:5], 0.0)
    assert "non-finite" in ctrl.receive([*Q0[:5], math.inf], 0.0)
    assert ctrl.receive([math.nan] * 6, 0.0) == ""  # all NaN: ignored, as the controller does
    assert np.allclose(ctrl.target, Q0)
    assert ctrl.receive(Q0 + 1.0, 0.0) == ""
    dt = 1 / 240
    q, v = ctrl.update(dt, dt, 1.0, Q0, np.zeros(6))
    assert np.all(np.abs(v) <= np.asarray(ur10e.JOINT_VELOCITY_LIMIT) + 1e-9)
    for _ in range(2000):
        q, _ = ctrl.update(dt, dt, 1.0, Q0, np.zeros(6))
    assert np.allclose(q, Q0 + 1.0)


def test_the_sim_paces_on_a_motions_end_and_waits_there_as_for_a_hold_if_it_comes_to_rest():
    ctrl = TrajectoryController(Q0)
    q0, q1, q2 = list(Q0), list(Q0 + 0.1), list(Q0 + 0.2)
    # the motion comes to rest at 0.06 and the snippet holds it to its horizon (0.08): the
    # commander reacts to the arm arriving, so the sim waits for it as for a hold
    resting = [(0.02, q0, [0.0] * 6, [], []), (0.06, q1, [0.0] * 6, [], []),
               (0.08, q1, [0.0] * 6, [], []), (0.58, q1, [0.0] * 6, [], [])]
    assert not ctrl.receive(list(JOINTS), 10.0, resting, now=10.0)
    assert ctrl.ends_at(10.0) == (pytest.approx(10.06), False, 10.0)
    # cut short mid-motion (the setpoints ran out at 0.04): commanded up to the cut only
    cut = [(0.02, q1, [0.0] * 6, [], []), (0.04, q2, [0.0] * 6, [], []),
           (0.54, q2, [0.0] * 6, [], [])]
    assert not ctrl.receive(list(JOINTS), 10.01, cut, now=10.01)
    assert ctrl.ends_at(10.01) == (pytest.approx(10.05), True, 10.01)
    holding = [(0.02, q1, [0.0] * 6, [], []), (0.08, q1, [0.0] * 6, [], []),
               (0.58, q1, [0.0] * 6, [], [])]
    assert not ctrl.receive(list(JOINTS), 10.02, holding, now=10.02)
    assert ctrl.ends_at(10.02) == (pytest.approx(10.10), False, 10.02)
