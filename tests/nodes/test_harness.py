"""The in-process harness: private context and domain, nodes that really talk over DDS."""

from __future__ import annotations

import os

import pytest
from densepack_interfaces.msg import GoalLayout
from rclpy.node import Node
from std_msgs.msg import String

from msgs_py import MessageError, load_scene
from msgs_py.ros import goal_layout_from_msg
from nodes.common.paths import config_path
from nodes.common.qos import LATCHED, RELIABLE
from nodes.goal.node import GoalPublisher

pytestmark = pytest.mark.ros


class Talker(Node):
    def __init__(self, **kwargs):
        super().__init__("talker", **kwargs)
        self.pub = self.create_publisher(String, "/chatter", RELIABLE)
        self.count = 0
        self.create_timer(0.05, self.tick)

    def tick(self):
        self.count += 1
        self.pub.publish(String(data=f"hello {self.count}"))


class Shouter(Node):
    """Repeats /chatter upper-cased on /shout: proves node -> node delivery."""

    def __init__(self, **kwargs):
        super().__init__("shouter", **kwargs)
        self.pub = self.create_publisher(String, "/shout", RELIABLE)
        self.create_subscription(String, "/chatter", self.on_chatter, RELIABLE)

    def on_chatter(self, msg):
        self.pub.publish(String(data=msg.data.upper()))


def test_each_session_runs_on_its_own_domain(ros):
    assert ros.domain_id == int(os.environ["ROS_DOMAIN_ID"])
    assert ros.domain_id != 0


def test_two_nodes_talk_through_the_harness(ros):
    ros.add(Talker(context=ros.context))
    ros.add(Shouter(context=ros.context))
    msg = ros.wait_for_message("/shout", String, lambda m: m.data.startswith("HELLO"), timeout=20)
    assert msg.data.startswith("HELLO ")


def test_wait_for_message_times_out(ros):
    with pytest.raises(TimeoutError, match=r"/silence"):
        ros.wait_for_message("/silence", String, timeout=0.5)


def test_goal_publisher_latches_the_scene_goal(ros):
    ros.add(GoalPublisher(context=ros.context))
    msg = ros.wait_for_message("/goal_layout", GoalLayout, timeout=20, qos=LATCHED)
    layout = goal_layout_from_msg(msg)
    scene = load_scene(config_path("scenes/default.yaml"))
    assert layout.blocks == () and layout.goal == scene.goal
    assert layout.workspace == scene.workspace


def test_goal_publisher_refuses_a_bad_scene_file(ros, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nworkspace: {x_min: 1, x_max: 0, y_min: 0, y_max: 1}\n")
    from rclpy.parameter import Parameter

    with pytest.raises(MessageError, match=r"workspace\.x_max"):
        GoalPublisher(context=ros.context,
                      parameter_overrides=[Parameter("scene_file", value=str(bad))])
