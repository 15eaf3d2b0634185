"""The executor's one input surface: what the core is told, and what the tick reads."""

from __future__ import annotations

import inspect

from msgs_py.status import GripperStatus
from nodes.executor.core import ExecutorCore
from nodes.executor.inputs import ExecutorInputs, Inbox
from nodes.executor.motion import ToolPose


def test_the_core_takes_every_input_of_the_surface_as_documented():
    """Whoever feeds the executor (the node today, an arm or gripper node later) calls these;
    the core must take each with the same parameters."""
    surface = {name: fn for name, fn in vars(ExecutorInputs).items()
               if callable(fn) and not name.startswith("_")}
    assert {"on_tcp", "on_gripper", "on_frame_taken", "on_detection",
            "on_arm_status"} <= set(surface)
    for name, fn in surface.items():
        assert list(inspect.signature(getattr(ExecutorCore, name)).parameters) == list(
            inspect.signature(fn).parameters), name


def test_gaps_are_kept_with_their_stamps_until_a_tick_takes_them():
    inbox = Inbox()
    inbox.on_finger_gap(0.05, None)  # no stamp: the latest gap, but no sample for a script
    inbox.on_finger_gap(0.051, 2.0)
    inbox.on_gripper(GripperStatus(0.052, 0.0, "stopped_closing", 3_000_000_000))
    assert inbox.finger_gap == 0.052
    assert inbox.take_gaps() == [(2.0, 0.051), (3.0, 0.052)] and inbox.take_gaps() == []
    assert [r.gap for r in inbox.take_readings()] == [0.052] and inbox.take_readings() == []
    inbox.on_tcp(ToolPose(0.5, 0.0, 0.3, 0.0), None)
    assert inbox.tcp_stamp is None and inbox.tcp.z == 0.3
