"""The client side of the ``/rearrange`` action: one goal sent, followed, and sent again when
its server went away."""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable
from typing import Any

from densepack_interfaces.action import Rearrange
from rclpy.action.client import ClientGoalHandle
from unique_identifier_msgs.msg import UUID

from msgs_py import Scene
from msgs_py.ros import (
    rearrange_feedback_from_msg,
    rearrange_goal_to_msg,
    rearrange_result_from_msg,
)
from nodes.cell.monitor import RunMonitor

#: A goal whose feedback (sent at least once a second) has been silent this long has lost its
#: server (the executor died): the goal is sent again (s).
GOAL_SILENCE_S = 10.0
#: A goal request unanswered this long is sent again (s).
GOAL_ANSWER_S = 10.0
#: A goal rejected when first sent is sent again after this long, this many times in all: the
#: client checked it already, so a rejection is the cell not being ready (the executor has not
#: yet taken the detection the client saw) until it happens again and again (s).
REJECTED_RETRY_S = 2.0
SENDS_WHEN_REJECTED = 3
#: After a cancel, wait this long for the goal's result (the arm lifts and parks) (s).
CANCEL_WAIT_S = 60.0


class GoalSender:
    """Sends a goal layout to ``/rearrange`` once the cell sees its blocks, follows its
    feedback into the monitor, and sends it again when its server went silent (an executor
    killed and restarted: the new one does not know the goal). ``outcome`` is set when the
    goal ends: a result outcome, or ``rejected``.

    Each goal carries an id made here, so a goal whose answer was lost on the way (DDS can
    drop a service response sent before the server has met the client's reader; the
    executor then runs a goal its client never heard accepted) is still recognised by its
    feedback and followed: sending it again would only be refused, the first one running."""

    def __init__(self, monitor: RunMonitor, layout: Scene) -> None:
        self.monitor = monitor
        self.goal = rearrange_goal_to_msg(layout)
        self.handle: Any = None  # the goal being followed
        self._sending: Any = None  # a goal request not answered yet
        self._sent_at = 0.0
        self._heard_at = 0.0
        self._result: Any = None
        self._rejected = 0
        self._sent_ids: set[bytes] = set()  # every goal id sent, answered or not
        self._running_id: Any = None  # a sent goal heard from in feedback before its answer
        self.outcome = ""
        self.resent = 0

    def step(self, now: float) -> None:
        if self.outcome:
            return
        if self.handle is None and self._running_id is not None:
            self._follow_unanswered(now)
        elif self._sending is not None:
            self._answer(now)
        elif self.handle is None:
            ready = self.monitor.rearrange.server_is_ready() and self.monitor.detection is not None
            if ready and now - self._sent_at >= REJECTED_RETRY_S * bool(self._rejected):
                self._send(now)
        elif self._result.done():
            self._finish(self._result.result())
        elif now - self._heard_at > GOAL_SILENCE_S:
            self.resent += 1
            self._send(now)

    def _send(self, now: float) -> None:
        goal_id = UUID(uuid=list(uuid.uuid4().bytes))
        self._sent_ids.add(bytes(goal_id.uuid))
        self._sending = self.monitor.rearrange.send_goal_async(
            self.goal, feedback_callback=self._on_feedback, goal_uuid=goal_id)
        self._sent_at = now

    def _follow_unanswered(self, now: float) -> None:
        """Our goal runs (its feedback says so) though its answer never came: follow it."""
        accepted = Rearrange.Impl.SendGoalService.Response(accepted=True)
        handle = ClientGoalHandle(self.monitor.rearrange, self._running_id, accepted)
        self.handle, self._result = handle, handle.get_result_async()
        self._sending, self._running_id, self._heard_at = None, None, now

    def _answer(self, now: float) -> None:
        if not self._sending.done():
            if now - self._sent_at > GOAL_ANSWER_S:
                self._sending = None  # lost on the way (no server yet): try again later
                self._heard_at = now
            return
        handle, self._sending = self._sending.result(), None
        self._heard_at = now
        if handle.accepted:
            self.handle, self._result = handle, handle.get_result_async()
        elif self.handle is None:
            self._rejected += 1
            self._sent_at = now
            if self._rejected >= SENDS_WHEN_REJECTED:
                self.outcome = "rejected"
        # else: a resend refused while the old goal still runs: keep following that one

    def _on_feedback(self, message: Any) -> None:
        self._heard_at = time.monotonic()
        if self.handle is None and bytes(message.goal_id.uuid) in self._sent_ids:
            self._running_id = message.goal_id
        feedback = rearrange_feedback_from_msg(message.feedback)
        with self.monitor.lock:
            self.monitor.feedback = feedback
            self.monitor.timeline.on_corrections(feedback.corrections)

    def _finish(self, answer: Any) -> None:
        result = rearrange_result_from_msg(answer.result)
        with self.monitor.lock:
            self.monitor.result = result
        self.outcome = result.outcome

    def cancel(self, spin: Callable[[], None], wait_s: float = CANCEL_WAIT_S) -> None:
        """Cancel the goal (a safe stop) and wait for its result, spinning with ``spin``."""
        if self.handle is None or self.outcome:
            return
        self.handle.cancel_goal_async()
        deadline = time.monotonic() + wait_s
        while not self._result.done() and time.monotonic() < deadline:
            spin()
        if self._result.done():
            self._finish(self._result.result())
