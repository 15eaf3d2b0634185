"""The arm-based calibration routine's pieces without ROS: yaw bookkeeping, its parameters,
and the scripts it plays (the executor's own)."""

from __future__ import annotations

import math

import pytest

from msgs_py import BlockPose
from nodes.calibration.arm_routine import ArmCalibration, ArmRoutineConfig, Phase, snap_yaw
from nodes.executor.config import ExecutorConfig
from nodes.executor.motion import ToolPose
from nodes.executor.steps import Grip


@pytest.mark.parametrize("tool,seen,expected", [
    (0.3, 0.31, 0.3),  # the tag's x axis along the closing axis
    (0.3, 0.3 + math.pi / 2 - 0.01, 0.3 + math.pi / 2),  # a quarter turn apart
    (0.3, 0.3 - math.pi + 0.01, 0.3 - math.pi),
    (3.1, -3.1, 3.1 - 2 * math.pi),  # across the wrap
])
def test_the_tag_picks_the_quarter_turn(tool, seen, expected):
    assert math.remainder(snap_yaw(tool, seen) - expected, 2 * math.pi) == pytest.approx(0.0)


@pytest.mark.parametrize("change,field", [
    ({"placements": [0.5, 0.0, 0.0] * 3}, "at least 4"),
    ({"placements": [0.5, 0.0] * 6 + [0.5]}, "triples"),
    ({"frames": 0}, "arm.frames"),
    ({"first_grasp_clearance": 0.02}, "first_grasp_clearance"),
])
def test_bad_parameters_are_refused(change, field):
    with pytest.raises(ValueError, match=field):
        ArmRoutineConfig(**change)


def test_the_first_grasp_straddles_a_centimetre_of_calibration_error():
    """Locate -> the re-grip script: pick wide where seen, put back, pick again with the
    closing axis turned 90 degrees, carry to the first placement, release, look."""
    routine = ArmCalibration(ArmRoutineConfig(block_id=3), ExecutorConfig())
    routine.on_tcp(ToolPose(0.25, -0.55, 0.40, 0.0), 0.0)
    assert routine.tick(0.0).want_frame
    routine.on_frame(0.1, (), {3: BlockPose(3, 0.64, 0.12, 0.4)})
    assert routine.phase is Phase.MOVE
    grips = [s for s in routine.runner.steps if isinstance(s, Grip)]
    openings = [round(g.opening * 1e3, 1) for g in grips]
    assert openings[0] == pytest.approx(50.8 + 2 * 16.0)  # the wide first grasp
    assert openings.count(0.0) == 2  # two grips: the second one turned 90 degrees
    above = [s.target for s in routine.runner.steps if s.label.endswith("travel above")]
    assert (above[0].x, above[0].y) == (above[1].x, above[1].y) == (0.64, 0.12)
    turn = math.remainder(above[1].yaw - above[0].yaw, math.pi)
    assert abs(turn) == pytest.approx(math.pi / 2)
    labels = [s.label for s in routine.runner.steps]
    assert labels[-1] == "look" and routine._release is grips[-1]


def test_a_late_tick_resumes_the_motion_where_it_was():
    """Held up for a second (a loaded machine), the routine does not jump along its path:
    consecutive setpoints stay within two ticks of travel, as the executor's do."""
    cfg = ExecutorConfig()
    routine = ArmCalibration(ArmRoutineConfig(block_id=3), cfg)
    routine.on_tcp(ToolPose(0.25, -0.55, 0.40, 0.0), 0.0)
    routine.tick(0.0)
    routine.on_frame(0.1, (), {3: BlockPose(3, 0.64, 0.12, 0.4)})
    previous = None
    for now in [0.2 + k / cfg.rate_hz for k in range(40)] + [2.0, 2.02, 2.04]:
        setpoint = routine.tick(now).setpoint
        if previous is not None:
            assert setpoint.distance_to(previous) <= 2 * cfg.speed / cfg.rate_hz + 1e-9
        previous = setpoint
        routine.on_tcp(setpoint, now)


def test_a_frame_before_the_arm_is_heard_from_is_waited_past_not_a_failure():
    """The first frame may come before the first /arm/tcp_pose (a loaded start, once in CI):
    the routine waits for a later frame, within its frame timeout, instead of failing."""
    cfg = ArmRoutineConfig(block_id=3)
    routine = ArmCalibration(cfg, ExecutorConfig())
    assert routine.tick(0.0).want_frame
    routine.on_frame(0.1, (), {3: BlockPose(3, 0.64, 0.12, 0.4)})
    assert routine.error == "" and routine.phase is Phase.LOCATE
    routine.on_tcp(ToolPose(0.25, -0.55, 0.40, 0.0), 0.2)
    assert routine.tick(5.0).want_frame  # asked again
    routine.on_frame(5.1, (), {3: BlockPose(3, 0.64, 0.12, 0.4)})
    assert routine.phase is Phase.MOVE
    silent = ArmCalibration(cfg, ExecutorConfig())
    silent.tick(0.0)
    silent.on_frame(0.1, (), {3: BlockPose(3, 0.64, 0.12, 0.4)})
    silent.tick(cfg.frame_timeout_s + 1.0)
    assert "no /arm/tcp_pose" in silent.error  # still bounded by the frame timeout
