"""Setpoint streams of the primitives: speed and acceleration limits, safe box, push line."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from msgs_py import PickPlace, Pose2D, Push
from msgs_py.cell import GripperGeometry
from nodes.executor.config import ExecutorConfig
from nodes.executor.grip import GRIP_STALL_S, GRIP_TIMEOUT_S, GRIPPER_SILENT_S
from nodes.executor.motion import Limits, LinearMove, ToolPose, move_duration
from nodes.executor.primitives import (
    action_steps,
    expected_after,
    fingers_off,
    park_steps,
    push_steps,
    release_opening,
)
from nodes.executor.steps import Grip, Move, Rise, StepFaultKind, StepRunner

CFG = ExecutorConfig()
GEO = GripperGeometry.from_params({})
RATE = 200.0


HOME = ToolPose(0.5, 0.0, 0.3, 0.0)


def play(steps, start=HOME, cfg=CFG, lag=0):
    """Stream a script with a perfectly tracking arm; returns [(t, label, setpoint, gripper)]."""
    runner = StepRunner(steps, start, cfg.convergence_tol, cfg.convergence_timeout_s,
                        cfg.in_safe_box)
    out, t, history = [], 0.0, [start]
    while not runner.finished:
        tick = runner.update(t, history[max(0, len(history) - 1 - lag)])
        assert not tick.error, tick.error
        out.append((t, tick.label, tick.setpoint, tick.gripper))
        history.append(tick.setpoint)
        t += 1.0 / RATE
        assert t < 600, "script never finished"
    return out


def speeds(stream):
    pos = np.array([s.position for _, _, s, _ in stream])
    v = np.linalg.norm(np.diff(pos, axis=0), axis=1) * RATE
    return v, np.abs(np.diff(v)) * RATE


@given(st.one_of(st.just(0.0), st.floats(1e-4, 1.0)), st.floats(0.05, 1.0), st.floats(0.1, 2.0),
       st.one_of(st.just(0.0), st.floats(1e-3, 3.0)))
def test_a_move_respects_its_limits_and_is_as_fast_as_they_allow(distance, speed, accel, dyaw):
    limits = Limits(speed, accel, 1.5, 3.0)
    move = LinearMove.plan(ToolPose(0, 0, 0.2, 0), ToolPose(distance, 0, 0.2, dyaw), limits)
    ts = np.linspace(0, move.duration, 2001)
    xs = np.array([move.sample(t).x for t in ts])
    if move.duration > 0:
        dt = ts[1] - ts[0]
        assert np.max(np.abs(np.diff(xs))) / dt <= speed * 1.001
        assert np.max(np.abs(np.diff(xs, 2))) / dt**2 <= accel * 1.01
    assert move.sample(move.duration) == move.end
    assert move.duration >= move_duration(distance, speed, accel) - 1e-12
    if dyaw == 0.0:  # the translation alone sets the profile: no slower than it must be
        assert move.duration == pytest.approx(move_duration(distance, speed, accel))


def pick():
    return PickPlace(3, Pose2D(0.55, -0.2, 0.4), Pose2D(0.70, 0.05, 0.0), grasp=1)


def push():
    start = Pose2D(0.60, 0.10, 0.3)
    d = (math.cos(0.3), math.sin(0.3))
    return Push(4, start, Pose2D(start.x + d[0] * 0.12, start.y + d[1] * 0.12, 0.3), d, 0.12)


@pytest.mark.parametrize("action", [pick(), push()], ids=["pick_place", "push"])
def test_streams_respect_speed_limits_and_safe_box(action):
    stream = play(action_steps(action, action.from_, GEO, CFG) + park_steps(CFG))
    v, a = speeds(stream)
    assert v.max() <= CFG.speed * 1.01
    assert a.max() <= CFG.accel * 1.05
    assert all(CFG.in_safe_box(s) for _, _, s, _ in stream)
    pushing = [s for _, label, s, _ in stream if label.endswith(": push")]
    if pushing:
        v_push, _ = speeds([(0, "", s, None) for s in pushing])
        assert v_push.max() <= CFG.push_speed * 1.01


def test_travel_happens_above_the_blocks():
    """Travel is at travel height; where the lift blends into the carry, the carried block
    (hanging grasp_height below the fingertips) still clears 5 cm blocks by a centimetre."""
    stream = play(action_steps(pick(), pick().from_, GEO, CFG))
    travel = [s for _, label, s, _ in stream if label.endswith(("travel above", "carry"))]
    clearance = min(s.z for s in travel) - CFG.grasp_height - GEO.block_size
    assert clearance >= 0.01
    assert travel[-1].z == pytest.approx(CFG.travel_height)
    carry = [s for _, label, s, _ in stream if label.endswith("carry")]
    assert carry[0].z < CFG.travel_height  # the corner is rounded: no stop at the top


def test_pick_place_grips_centred_with_the_right_axis_and_places_at_the_goal():
    action = pick()
    steps = action_steps(action, action.from_, GEO, CFG)
    descend = next(s for s in steps
                   if isinstance(s, Move) and s.label.endswith("descend (last cm)"))
    assert (descend.target.x, descend.target.y) == (0.55, -0.2)
    assert descend.target.z == CFG.grasp_height
    # grasp 1 closes along the block's local y axis: tool yaw = theta + 90 deg (mod 180)
    assert math.remainder(descend.target.yaw - (0.4 + math.pi / 2), math.pi) == pytest.approx(0)
    lower = next(s for s in steps if isinstance(s, Move) and s.label.endswith("lower (last cm)"))
    assert (lower.target.x, lower.target.y) == (0.70, 0.05)
    assert lower.target.z == pytest.approx(CFG.grasp_height + CFG.place_drop)
    # the tool turns by exactly the block's change of yaw (mod 180 deg)
    turn = lower.target.yaw - descend.target.yaw
    assert math.remainder(turn - (0.0 - 0.4), math.pi) == pytest.approx(0, abs=1e-12)
    grips = [s for s in steps if isinstance(s, Grip)]
    assert grips[0].opening == pytest.approx(0.0508 + 2 * GEO.approach_clearance)
    assert [g.opening for g in grips if g.holds == action.block] == [CFG.grip_command]
    before_descent = steps[steps.index(descend) - 3]  # the fingers are open before going down
    assert isinstance(before_descent, Grip) and before_descent.wait
    assert before_descent.opening == grips[0].opening
    # ... and come in to the release opening, not waited for, as the last cm begins
    closing_in = steps[steps.index(descend) - 1]
    assert isinstance(closing_in, Grip) and not closing_in.wait
    assert closing_in.opening == pytest.approx(release_opening(GEO, CFG))
    assert closing_in.opening < grips[0].opening - 0.005


def test_the_fingers_come_in_during_the_last_cm_only_when_they_are_beside_the_block():
    """Fingertips that start the last cm above the block's top (a high grasp) keep the pick
    opening until the grip: a finger coming in above a block standing off would land on it."""
    action = pick()
    high = dataclasses.replace(CFG, grasp_height=0.03)
    for cfg, closes_in in ((CFG, True), (high, False)):
        steps = action_steps(action, action.from_, GEO, cfg)
        grips = [s for s in steps if isinstance(s, Grip) and s.label.endswith("fingers in")]
        assert bool(grips) is closes_in


def test_push_streams_along_the_line_through_the_block_centre():
    action = push()
    stream = play(push_steps(action, action.from_, GEO, CFG))
    d = np.array(action.direction)
    normal = np.array([-d[1], d[0]])
    centre = np.array([action.from_.x, action.from_.y])
    pushing = [s for _, label, s, _ in stream if label.endswith((": push", "descend behind"))]
    for s in pushing:
        assert abs(normal @ (np.array([s.x, s.y]) - centre)) < 1e-9  # on the push line
    low = [s for s in pushing if s.z == pytest.approx(CFG.push_height)]
    # fingertips start push_contact_depth behind the rear face, end on the goal's rear face
    front = GEO.finger_width / 2
    start_gap = (centre - [low[0].x, low[0].y]) @ d - GEO.block_size / 2 - front
    assert start_gap == pytest.approx(GEO.push_contact_depth)
    end_face = ([low[-1].x, low[-1].y] - np.array([action.to.x, action.to.y])) @ d + front
    assert end_face == pytest.approx(-GEO.block_size / 2, abs=1e-6)
    # the closing axis is perpendicular to the push
    assert abs(math.cos(low[0].yaw - math.atan2(d[1], d[0]))) < 1e-9


def test_push_from_a_perceived_pose_ends_at_the_planned_point_along_the_line():
    action = push()
    d = np.array(action.direction)
    perceived = Pose2D(action.from_.x - 0.002 * d[0], action.from_.y - 0.002 * d[1], 0.3)
    end = expected_after(action, perceived, GEO)
    assert (end.x, end.y) == pytest.approx((action.to.x, action.to.y))


def test_a_step_outside_the_safe_box_is_refused_with_its_name():
    far = PickPlace(1, Pose2D(0.6, 0.0), Pose2D(1.6, 0.0), 0)
    runner = StepRunner(action_steps(far, far.from_, GEO, CFG), ToolPose(0.5, 0, 0.3, 0),
                        CFG.convergence_tol, CFG.convergence_timeout_s, CFG.in_safe_box)
    t, tick = 0.0, None
    while t < 60:
        tick = runner.update(t, runner.commanded)
        if tick.error:
            break
        t += 0.01
    assert "carry" in tick.error and "outside the safe box" in tick.error


def test_a_tcp_that_never_arrives_is_reported():
    runner = StepRunner([Move(ToolPose(0.6, 0, 0.2, 0), CFG.travel_limits, "go")],
                        ToolPose(0.5, 0, 0.2, 0), 0.002, 1.0)
    stuck = ToolPose(0.5, 0, 0.2, 0)
    t = 0.0
    while t < 10 and not (tick := runner.update(t, stuck)).error:
        t += 0.01
    assert "TCP did not reach" in tick.error and "100.0 mm" in tick.error


def test_a_lagging_arm_delays_but_does_not_break_the_script():
    stream = play(action_steps(pick(), pick().from_, GEO, CFG), lag=20)
    assert stream[-1][2].z == pytest.approx(CFG.travel_height)


def test_config_rejects_a_park_pose_outside_the_safe_box():
    with pytest.raises(ValueError, match="park_pose"):
        ExecutorConfig(park_pose=(3.0, 0.0, 0.5, 0.0))


def test_a_zero_wait_grip_still_reaches_the_gripper():
    """Regression: the push's 'close to push' (no settle time) was swallowed by the next move."""
    action = push()
    stream = play(push_steps(action, action.from_, GEO, CFG))
    commands = [g for _, _, _, g in stream if g is not None]
    assert commands == [GEO.push_opening]


def tool_yaws(action, period=math.pi):
    return [step.target.yaw for step in action_steps(action, action.from_, GEO, CFG,
                                                     turn_period=period)
            if isinstance(step, Move)]


def random_pick_places(seed, n=200):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        theta, to_theta = rng.uniform(-math.pi, math.pi, 2)
        yield PickPlace(1, Pose2D(0.6, 0.0, theta), Pose2D(0.7, 0.1, to_theta),
                        int(rng.integers(2)))


def test_tool_yaws_stay_near_the_park_yaw():
    """Regression: yaws chosen relative to the current one wandered action after action
    until the wrist ran into its limit and the IK swung the arm onto another branch. Pick
    and place are centred on the park yaw: each within a quarter turn and half the hand's
    turn of it."""
    for action in random_pick_places(5):
        for yaw in tool_yaws(action):
            assert abs(yaw - CFG.park.yaw) <= math.pi / 2 + math.pi / 4 + 1e-9


def test_the_wrist_turns_a_cube_at_most_a_quarter_turn_and_sets_it_down_as_planned():
    """Regression: each yaw on its own nearest the park yaw turned blocks up to 180 deg in
    the hand (the cell's release stalls came after such turns). The block ends at its goal
    yaw or a half turn from it: the fingers then stand where the planner checked them (a
    quarter turn would put them across the other axis, into the neighbours)."""
    for action in random_pick_places(6):
        yaws = tool_yaws(action)
        turn = yaws[-1] - yaws[0]  # the wrist turns the held block by this
        assert abs(turn) <= math.pi / 2 + 1e-9
        placed = action.from_.theta + turn
        assert abs(math.remainder(placed - action.to.theta, math.pi)) < 1e-9


def test_a_yaw_exact_goal_gets_the_block_at_exactly_its_yaw():
    """With ``yaw_exact`` a quarter turn is not the same: the hand turns the block to the
    goal's own yaw (before, a half turn could be added to keep the tool near the park yaw)."""
    for action in random_pick_places(7):
        yaws = tool_yaws(action, 2 * math.pi)
        placed = action.from_.theta + yaws[-1] - yaws[0]
        assert abs(math.remainder(placed - action.to.theta, 2 * math.pi)) < 1e-9
        for yaw in yaws:
            assert abs(yaw - CFG.park.yaw) <= math.pi + 1e-9


def test_a_rise_never_goes_down():
    runner = StepRunner(park_steps(CFG), ToolPose(0.25, -0.55, 0.40, 0.0), 0.002, 1.0)
    tick = runner.update(0.0, ToolPose(0.25, -0.55, 0.40, 0.0))
    assert tick.setpoint.z == pytest.approx(0.40)


def test_a_late_measurement_delays_the_verdict_instead_of_failing():
    """On a loaded machine /tcp_pose can arrive seconds (of sim time) late."""
    runner = StepRunner([Move(ToolPose(0.6, 0, 0.2, 0), CFG.travel_limits, "go")],
                        ToolPose(0.5, 0, 0.2, 0), 0.002, 1.0)
    old = ToolPose(0.5, 0, 0.2, 0)
    for t in np.arange(0.0, 4.0, 0.01):  # measurements still from t = 0
        assert not runner.update(float(t), old, measured_at=0.0).error
    tick = runner.update(4.0, ToolPose(0.6, 0, 0.2, 0), measured_at=3.9)
    assert tick.done and not tick.error


def run_grip(gaps_at, opening, until=2.0):
    """Play one Grip against a gripper reporting gaps_at(t) every 20 ms; (time done, error)."""
    runner = StepRunner([Grip(opening, 0.3, "grip")], HOME, 0.002, 1.0)
    t = 0.0
    while t < until:
        tick = runner.update(t, HOME, gaps=[(t, gaps_at(t))])
        if tick.done or tick.error:
            return t, tick.error
        t += 0.02
    return None, ""


def test_a_grip_is_done_when_the_fingers_stop_on_the_block_not_after_a_fixed_wait():
    def closing(t):  # 68.8 mm closing at 150 mm/s from t = 0.04, stopped by a 50.8 mm block
        return max(0.0508, 0.0688 - 0.15 * max(0.0, t - 0.04))

    done, error = run_grip(closing, 0.0)
    assert not error and done == pytest.approx(0.16 + 0.04, abs=0.03)


def test_a_grip_that_reaches_its_opening_is_done_at_once_and_one_that_never_moves_later():
    done, _ = run_grip(lambda t: 0.0688, 0.0688)  # already open
    assert done == pytest.approx(0.04, abs=0.021)
    done, _ = run_grip(lambda t: 0.0508, 0.0)  # already stopped on a block: no motion
    assert 0.29 <= done <= 0.35


def test_fingers_already_at_an_opening_they_were_sent_are_done_at_once():
    """Each action's "fingers open" waits for the opening the fingers were shaped to on the
    way (no command sent): fingers there are done on the first report, with no wait for a
    command to reach the gripper; fingers short of it are waited for as before."""
    steps = [Grip(0.0688, 0.0, "shape", wait=False), Grip(0.0688, 0.3, "fingers open")]
    runner = StepRunner(steps, HOME, 0.002, 1.0)
    assert runner.update(0.0, HOME, gaps=[(0.0, 0.0688)]).done
    coming = StepRunner(steps, HOME, 0.002, 1.0)
    assert not coming.update(0.0, HOME, gaps=[(0.0, 0.0650)]).done


def test_a_release_that_pauses_on_the_block_is_not_done_until_the_fingers_are_open():
    def opening(t):  # 50.8 -> 68.8 mm at 150 mm/s, a pad dragging on the block 0.1-0.2 s
        moved = 0.15 * max(0.0, t - 0.04)
        if t > 0.1:
            moved = max(0.15 * 0.06, 0.15 * (t - 0.14)) if t > 0.2 else 0.15 * 0.06
        return min(0.0688, 0.0508 + moved)

    done, error = run_grip(opening, 0.0688)
    assert not error and done >= 0.2 + (0.0688 - 0.0508 - 0.009) / 0.15 - 0.03


def test_a_release_is_done_once_the_pads_are_off_the_block():
    """The 2F-85 slows down into its last millimetre (in the cell: 58.1, 58.4, 58.5, 58.7 mm
    a report apart, opening to 58.8): a release is done at the gap that leaves its block, the
    tool rising while the fingers open on; fingers held at the block are not released."""
    off_at = fingers_off(GEO, CFG)
    assert GEO.block_size < off_at < release_opening(GEO, CFG)
    runner = StepRunner([Grip(0.0588, 0.3, "release", off_at=off_at)], HOME, 0.002, 1.0)
    gaps = [0.0508, 0.0508, 0.0527, 0.0552, 0.0567, 0.0575, 0.0581, 0.0584, 0.0585, 0.0587]
    done = [runner.update(0.02 * k, HOME, gaps=[(0.02 * k, g)]).done for k, g in enumerate(gaps)]
    assert done.index(True) == next(k for k, g in enumerate(gaps) if g >= off_at)
    held = StepRunner([Grip(0.0588, 0.3, "release", off_at=off_at)], HOME, 0.002, 1.0)
    assert not any(held.update(0.02 * k, HOME, gaps=[(0.02 * k, 0.0512)]).done
                   for k in range(30))


def test_a_grip_is_not_done_by_the_fingers_coming_to_rest_from_the_command_before_it():
    """The fingers still coming in to 58.8 mm (sent during the descent) when the tool has
    converged at grasp height: they stop there before the grip reaches the gripper, which
    is not the grip stopping on a block (it was judged a miss on nothing, 16 blocks seed 7);
    the grip is done once they stop on the block at 50.8 mm."""
    steps = [Grip(0.0588, 0.0, "fingers in", wait=False), Grip(0.0, 0.3, "grip", holds=1)]
    runner = StepRunner(steps, HOME, 0.002, 1.0)

    def gap(t):  # at rest at 58.8 from 0.04 s; the grip's command acts from 0.14 s
        return 0.0600 - 0.03 * min(t, 0.04) if t < 0.14 else max(0.0508, 0.0588 - 0.15 * (t - 0.14))

    done_at = next(t for t in np.arange(0.0, 1.0, 0.02)
                   if runner.update(float(t), HOME, gaps=[(float(t), gap(float(t)))]).done)
    assert done_at >= 0.14 + (0.0588 - 0.0508) / 0.15


def stalled(tick) -> bool:
    return tick.fault is not None and tick.fault.kind is StepFaultKind.STALLED


def stalls_at(gap):
    """50.9 -> 68.8 mm at 150 mm/s from t = 0.04, held fast at ``gap`` on the way."""
    return lambda t: min(gap, 0.0509 + 0.15 * max(0.0, t - 0.04))


def test_an_opening_that_stalls_short_is_reported_as_stalled_long_before_the_timeout():
    """Seen in the cell: released, the fingers opened 2 mm and stopped; the run waited 3 s
    and stopped. A stalled opening is now its own verdict, for the executor to recover."""
    runner = StepRunner([Grip(0.0688, 0.3, "block 4: release")], HOME, 0.002, 1.0)
    t, tick = 0.0, None
    while t < GRIP_TIMEOUT_S:
        tick = runner.update(t, HOME, gaps=[(t, stalls_at(0.0529)(t))])
        if tick.done or tick.error:
            break
        t += 0.02
    assert tick is not None and stalled(tick) and not tick.done
    assert t <= 0.04 + 0.02 / 0.15 + GRIP_STALL_S + 0.05
    assert "stopped opening at 52.9 mm (asked for 68.8 mm)" in tick.error


def test_a_release_tried_again_gets_its_own_time_before_it_counts_as_stalled():
    """In the cell, the release tried again after a stall was judged stalled 0.13 s later,
    on the samples from before it; it must be given GRIP_STALL_S of its own."""
    runner = StepRunner([Grip(0.0688, 0.3, "release")], HOME, 0.002, 1.0)
    t, tick = 0.0, None
    while not (tick and stalled(tick)):
        tick = runner.update(t, HOME, gaps=[(t, 0.0526)])
        t += 0.02
    up = ToolPose(HOME.x, HOME.y, HOME.z + 0.003, HOME.yaw)
    runner.retry_current([Move(up, CFG.approach_limits, "unload")])
    retried_at = None
    while t < 10.0:
        tick = runner.update(t, up, gaps=[(t, 0.0526)])
        if retried_at is None and runner.current_label == "release":
            retried_at = t
        if stalled(tick):
            break
        t += 0.02
    assert retried_at is not None and t - retried_at >= GRIP_STALL_S - 0.03


def test_a_step_tried_again_runs_after_what_goes_before_it_then_the_rest_follows():
    up = ToolPose(HOME.x, HOME.y, HOME.z + 0.003, HOME.yaw)
    after = Move(ToolPose(HOME.x, HOME.y, HOME.z + 0.1, HOME.yaw), CFG.vertical_limits, "retreat")
    runner = StepRunner([Grip(0.0688, 0.3, "release"), after], HOME, 0.002, 1.0)
    runner.update(0.0, HOME, gaps=[(0.0, 0.0509)])
    runner.retry_current([Move(up, CFG.approach_limits, "unload")])
    assert [s.label for s in runner.steps] == ["unload", "release", "retreat"]
    t, tool, labels = 0.0, HOME, []
    while not runner.finished and t < 5.0:
        t += 0.02  # the fingers held on the block until the unload is done, then open
        gap = 0.0509 if runner.current_label == "unload" else 0.0688
        tick = runner.update(t, tool, gaps=[(t, gap)])
        tool = tick.setpoint
        labels.append(runner.current_label)
    assert labels.index("release") > labels.index("unload")
    assert runner.finished and tool.z == pytest.approx(HOME.z + 0.1)


def test_a_gripper_that_neither_arrives_nor_stops_is_an_error():
    _, error = run_grip(lambda t: 0.0688 - 0.005 * t, 0.0, until=5.0)  # a slow creep
    assert "gripper neither reached 0.0 mm nor stopped" in error


def test_a_release_waits_for_a_gripper_node_that_went_silent_and_its_time_starts_when_it_is_back():
    """Chaos (the gripper node SIGKILLed as the fingers opened on a block): the release was
    taken as done after the 0.3 s wait for a gripper that reports nothing, the arm left the
    block in the fingers. A gripper that has reported before is waited for; once back (4 s
    later), the opening gets its own time to be judged."""
    runner = StepRunner([Grip(0.0688, 0.3, "release")], HOME, 0.002, 1.0)
    runner.update(0.0, HOME, gaps=[(0.0, 0.0508)], gripper_reports=True)
    t, tick = 0.02, None
    while t < 4.0:  # nothing comes: the node is down
        tick = runner.update(t, HOME, gripper_reports=True)
        assert not tick.done and not tick.error
        t += 0.02
    back = t
    while t < back + 2.0:  # back, it stands closed for 0.4 s, then opens at 150 mm/s
        gap = min(0.0688, 0.0508 + 0.15 * max(0.0, t - back - 0.4))
        tick = runner.update(t, HOME, gaps=[(t, gap)], gripper_reports=True)
        assert not tick.error
        if tick.done:
            break
        t += 0.02
    assert tick is not None and tick.done and t >= back + 0.4 + 0.018 / 0.15 - 0.03


def test_a_long_silent_gripper_is_an_error_one_that_never_reports_waits_the_settle_time():
    runner = StepRunner([Grip(0.0688, 0.3, "release")], HOME, 0.002, 1.0)
    t, tick = 0.0, None
    while t < GRIPPER_SILENT_S + 1.0:
        tick = runner.update(t, HOME, gripper_reports=True)
        if tick.error:
            break
        t += 0.02
    assert tick is not None and tick.fault is not None
    assert tick.fault.kind is StepFaultKind.GRIPPER_TIMEOUT
    assert "reported nothing" in tick.error and t >= GRIPPER_SILENT_S
    silent = StepRunner([Grip(0.0688, 0.3, "release")], HOME, 0.002, 1.0)
    assert not silent.update(0.0, HOME).done and silent.update(0.32, HOME).done


def test_a_blended_corner_stays_within_its_radius_and_under_the_speed_limit():
    start, corner, end = ToolPose(0.6, 0.0, 0.012, 0.0), ToolPose(0.6, 0.0, 0.1, 0.0), \
        ToolPose(0.9, 0.0, 0.1, 0.0)
    steps = [Move(corner, CFG.vertical_limits, "lift", blend=CFG.blend_radius),
             Move(end, CFG.travel_limits, "carry")]
    stream = play(steps, start=start)
    xs = np.array([s.position for _, _, s, _ in stream])
    v, _ = speeds(stream)
    assert v.max() <= CFG.speed * 1.01
    # the corner is cut, but never by more than the radius: no point below the lift's line
    # while still near its x, nor further than the radius from the two segments
    cut = xs[(xs[:, 0] > 0.6 + 1e-6) & (xs[:, 2] < 0.1 - 1e-6)]
    assert len(cut) > 0
    assert np.all(0.1 - cut[:, 2] <= CFG.blend_radius + 1e-9)
    assert np.all(cut[:, 0] - 0.6 <= CFG.blend_radius + 1e-9)
    no_blend = play([Move(corner, CFG.vertical_limits, "lift"),
                     Move(end, CFG.travel_limits, "carry")], start=start)
    assert len(stream) < len(no_blend)  # and it is faster


def test_braking_stops_a_move_on_its_line_within_the_deceleration():
    runner = StepRunner([Move(ToolPose(1.0, 0.0, 0.3, 0.0), CFG.travel_limits, "go")],
                        HOME, 0.002, 1.0)
    t, last = 0.0, HOME
    while t < 0.4:  # well into the move, at speed
        last = runner.update(t, last).setpoint
        t += 0.005
    speed = math.hypot(*runner.velocity(t - 0.005))
    assert speed > 0.3
    runner.brake(t, decel=5.0)
    stream = []
    while not runner.finished:
        tick = runner.update(t, last)
        stream.append(tick.setpoint)
        last = tick.setpoint
        t += 0.005
    xs = np.array([p.x for p in stream])
    assert np.all(np.diff(xs) >= -1e-12)  # on along the line, never back
    assert np.max(np.abs(np.diff(xs, 2))) / 0.005**2 <= 5.0 * 1.01  # within the deceleration
    assert xs[-1] - stream[0].x <= speed**2 / (2 * 5.0) + 0.01
    assert all(p.y == 0.0 and p.z == pytest.approx(0.3) for p in stream)


def test_a_set_down_block_is_let_go_with_less_opening_than_the_pick_went_down_with():
    """The plan checks the fingers open to the approach opening at the place pose, and may
    leave one flush with a placed neighbour; the release opens only release_clearance, so
    that finger stays millimetres off (16 blocks, seed 10: it brushed the neighbour)."""
    action = PickPlace(1, Pose2D(0.55, -0.2, 0.3), Pose2D(0.70, 0.0, 0.0), 0)
    grips = {s.label: s.opening for s in action_steps(action, action.from_, GEO, CFG)
             if isinstance(s, Grip)}
    assert grips["block 1: fingers open"] == pytest.approx(GEO.approach_opening)
    assert grips["block 1: release"] == pytest.approx(GEO.block_size + 2 * CFG.release_clearance)
    assert GEO.approach_clearance - CFG.release_clearance >= 0.003


@pytest.mark.parametrize("lag", [0, 30])
def test_the_next_action_shapes_the_fingers_only_once_the_tool_is_up(lag):
    """Regression (25 blocks, seeds 1 and 5): a block set down on its push line, then pushed.
    The push's script began while the lagging arm was still at the set-down, and its first
    step closed the fingers to the push opening there: they gripped the block just released
    and carried it off. Every finger command of the next script now waits until the measured
    TCP stands at travel height."""
    place = PickPlace(4, Pose2D(0.55, -0.2, 0.0), Pose2D(0.60, 0.10, 0.3), grasp=0)
    then = push()
    history = [HOME]
    for steps in (action_steps(place, place.from_, GEO, CFG),
                  action_steps(then, then.from_, GEO, CFG)):
        runner = StepRunner(steps, history[-1], CFG.convergence_tol, CFG.convergence_timeout_s,
                            CFG.in_safe_box)
        t, measured_at_command = 0.0, []
        while not runner.finished:
            measured = history[max(0, len(history) - 1 - lag)]
            tick = runner.update(t, measured)
            assert not tick.error, tick.error
            if tick.gripper is not None:
                measured_at_command.append((tick.gripper, measured.z))
            history.append(tick.setpoint)
            t += 1.0 / RATE
    shape = measured_at_command[0]  # the push's first finger command
    assert shape[0] == pytest.approx(GEO.push_opening)
    assert shape[1] >= CFG.travel_height - CFG.convergence_tol


def test_an_action_does_not_go_down_before_the_tool_is_above_its_block():
    """The next action's rise, at travel height already, waits for the measured tool to be
    there in all three axes: in a 25-block scene (seed 5) the arm stood 32 mm short of a
    block near the workspace's corner, and a rise judged on its height alone let the descent
    start; a finger came down on the block (protective stop, the block lost)."""
    top = ToolPose(0.9953, 0.4027, CFG.travel_height, 0.0)
    steps = [Rise(CFG.travel_height, CFG.vertical_limits), Move(top.with_z(0.03),
                                                                 CFG.vertical_limits, "down")]
    runner = StepRunner(steps, top, CFG.convergence_tol, CFG.convergence_timeout_s)
    short = ToolPose(0.9798, 0.3753, CFG.travel_height, 0.0)
    for k in range(50):
        tick = runner.update(0.02 * k, short)
        assert tick.setpoint.z == CFG.travel_height and not tick.done
    runner.update(1.0, top)  # there: the descent begins
    assert runner.update(1.1, top).setpoint.z < CFG.travel_height
