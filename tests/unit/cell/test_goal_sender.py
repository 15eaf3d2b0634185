"""The run tools' goal client follows a goal whose answer was lost on the way."""

from __future__ import annotations

import threading

from rclpy.task import Future

from msgs_py import Goal, GoalSlot, Scene, Workspace
from nodes.cell.goal_sender import GoalSender

#: A goal layout of one slot (what it holds does not matter to the client).
LAYOUT = Scene(Workspace(0.4, 1.0, -0.3, 0.3), 0.0508, (),
               Goal(slots=(GoalSlot(0.7, 0.0, 0.0, 0),)))


class FakeActionClient:
    """Accepts goals but never answers them (the response lost); records result requests."""

    def __init__(self) -> None:
        self.sent: list = []
        self.result_requests: list = []

    def server_is_ready(self) -> bool:
        return True

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None):
        self.sent.append((goal_uuid, feedback_callback))
        return Future()  # never answered

    def _get_result_async(self, handle):
        self.result_requests.append(handle.goal_id)
        return Future()


class FakeMonitor:
    def __init__(self) -> None:
        self.rearrange = FakeActionClient()
        self.detection = object()
        self.lock = threading.Lock()
        self.feedback = None
        self.timeline = type("T", (), {"on_corrections": lambda self, n: None})()


def feedback_for(goal_id):
    from densepack_interfaces.action import Rearrange

    msg = Rearrange.Impl.FeedbackMessage()
    msg.goal_id = goal_id
    msg.feedback.state = 2  # running
    msg.feedback.block = -1
    return msg


def test_a_goal_whose_answer_was_lost_is_followed_by_its_feedback_not_sent_again():
    monitor = FakeMonitor()
    sender = GoalSender(monitor, LAYOUT)
    sender.step(0.0)
    assert len(monitor.rearrange.sent) == 1
    goal_id, on_feedback = monitor.rearrange.sent[0]
    on_feedback(feedback_for(goal_id))  # the executor runs it: feedback comes, no answer
    sender.step(1.0)
    assert sender.handle is not None and monitor.rearrange.result_requests == [goal_id]
    # past the time an unanswered request is given up (then it would be sent again, and
    # refused: the first one runs), the goal is followed, not sent again
    sender.step(10.5)
    sender.step(10.6)
    assert len(monitor.rearrange.sent) == 1 and not sender.outcome


def test_feedback_of_a_goal_not_ours_is_not_adopted():
    from unique_identifier_msgs.msg import UUID

    monitor = FakeMonitor()
    sender = GoalSender(monitor, LAYOUT)
    sender.step(0.0)
    _, on_feedback = monitor.rearrange.sent[0]
    on_feedback(feedback_for(UUID(uuid=[7] * 16)))
    sender.step(1.0)
    assert sender.handle is None and monitor.rearrange.result_requests == []
