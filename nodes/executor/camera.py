"""The camera as the executor drives it: when a look's frame is triggered, and which
frame's detection counts for it.

A look from the look pose or the park pose triggers once the arm is there. A look on the way
(``observe.look_on_the_way``) triggers where the measured tool reaches the pose picked for the
frame from the arm's predicted silhouette: but the measured arm runs a servo delay and more
behind its setpoints and rounds corners, so the frame could catch a block to judge covered
after all (about one look a run), and the arm then had to look again from the look pose.
So the trigger also asks the arm's measured posture (``shows``: the joints the arm reported,
and where they will be a frame's delay later): it waits, past the picked pose if need be,
for a posture that leaves those blocks in view.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from msgs_py import BlockSet
from nodes.executor.motion import ToolPose
from nodes.executor.report import Report
from nodes.executor.states import Purpose

#: On the way, the frame is taken when the measured tool comes this close to the pose picked
#: for it (m), or passes it within PASSING_M.
AT_POSE_M = 0.01
PASSING_M = 0.05

#: A detection this long after its camera trigger (s) came late. Trigger, render, transfer
#: and detection take 0.5-1.5 s in the cell; a reliable frame or detection whose lost
#: fragment waits for the DDS writer's next heartbeat (3 s by default) takes longer.
LATE_DETECTION_S = 2.0


@dataclass
class Camera:
    """The look under way: what its frame is for, the triggers made for it, and which frame
    counts (the first taken at or after ``trigger_ns``; None: none asked for)."""

    purpose: Purpose = Purpose.START
    triggers: int = 0
    trigger_ns: int | None = None
    trigger_time: float = 0.0  #: when the last trigger went out (s)
    frame_taken: bool = False  #: the camera answered it: the arm may move on
    arrived: BlockSet | None = None  #: the detection, come while the arm moved on
    want_trigger: bool = False  #: for the next tick's outputs
    last_idle_look: float | None = None
    #: on the way: trigger where the measured tool passes this pose (the arm follows its
    #: setpoints a servo delay and more behind: the script's time would be early)
    trigger_near: ToolPose | None = None
    near_dist: float = math.inf  #: how close the measured tool has come to it so far (m)
    reached: bool = False  #: the measured tool came to it, or passed it
    held_back: int = 0  #: ticks the trigger waited there for the arm to uncover a block
    on_the_way: bool = False  #: the frame is taken with the arm in view, moving on
    judge: frozenset[int] = frozenset()  #: on the way: blocks the frame must show uncovered

    def begin(self, purpose: Purpose, keep_tries: bool = False) -> None:
        self.purpose = purpose
        if not keep_tries:
            self.triggers = 0
        self.trigger_ns = None
        self.arrived = None
        self.trigger_near = None
        self.near_dist = math.inf
        self.reached = False
        self.held_back = 0
        self.on_the_way = False
        self.judge = frozenset()

    def due(self, now: float, tcp: ToolPose | None,
            shows: Callable[[], bool] | None = None, force: bool = False) -> bool:
        """Trigger now if the measured tool ``tcp`` is at the pose picked on the way, or has
        passed it (it came within PASSING_M and goes away again), and the arm's measured
        posture ``shows`` the blocks to judge (None: not known; then the pose alone); or
        ``force``."""
        if self.trigger_near is None:
            return False
        dist = math.inf if tcp is None else tcp.distance_to(self.trigger_near)
        passed = self.near_dist < PASSING_M and dist > self.near_dist
        self.near_dist = min(self.near_dist, dist)
        self.reached = self.reached or dist < AT_POSE_M or passed
        if not (force or self.reached):
            return False
        if not force and shows is not None and not shows():
            self.held_back += 1
            return False
        self.trigger_near = None
        self.trigger(now)
        return True

    def trigger(self, now: float) -> None:
        self.triggers += 1
        self.trigger_time = now
        self.trigger_ns = round(now * 1e9)
        self.frame_taken = False
        self.want_trigger = True

    def on_frame_taken(self, stamp_ns: int) -> None:
        """The camera answered the trigger: its frame was taken at ``stamp_ns``."""
        if self.trigger_ns is not None:
            self.trigger_ns = max(self.trigger_ns, stamp_ns)
            self.frame_taken = True

    def late(self, frame_stamp_ns: int, now: float) -> str | None:
        """Where the time went, when the detection of the frame stamped ``frame_stamp_ns``
        comes LATE_DETECTION_S or more after the trigger (None: in time): so that a slow
        link shows in a long run's log, named by its side of the camera."""
        waited = now - self.trigger_time
        if waited < LATE_DETECTION_S:
            return None
        taken = frame_stamp_ns * 1e-9 - self.trigger_time
        return (f"detection {waited:.1f} s after the camera trigger: the frame taken "
                f"{taken:.1f} s after the trigger, its detection here {waited - taken:.1f} s "
                "after that")

    def accepts(self, detection: BlockSet) -> bool:
        """Whether ``detection`` is of the frame asked for (then no other counts)."""
        if self.trigger_ns is None or detection.stamp_ns < self.trigger_ns:
            return False
        self.trigger_ns = None
        return True


def count_detection(camera: Camera, frame_stamp_ns: int, now: float, report: Report) -> None:
    """An accepted detection: one more observation; a late one counted and explained."""
    report.count("observations")
    late = camera.late(frame_stamp_ns, now)
    if late is not None:
        report.count("late_detections")
        report.log(late)
