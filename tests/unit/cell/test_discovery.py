"""Nodes expected on another computer: seen by name or by their topic, reported within
seconds when never seen or gone, with what to check."""

from __future__ import annotations

from nodes.cell.discovery import (
    SIGNATURE_TOPICS,
    DiscoveryWatch,
    GraphView,
    discovery_hint,
    discovery_ports,
    graph_view,
)
from nodes.cell.launch import NODE_MODULES

REMOTE = ("sim", "detector", "arm", "gripper")
LOCAL = GraphView(frozenset({"planner", "executor", "densepack_run"}),
                  frozenset({"/planner/status", "/executor/status"}))
ALL = GraphView(LOCAL.nodes | set(REMOTE), LOCAL.published)


def test_every_node_of_the_cell_but_the_goal_has_a_topic_of_its_own():
    assert set(SIGNATURE_TOPICS) == set(NODE_MODULES) - {"goal"}
    assert len(set(SIGNATURE_TOPICS.values())) == len(SIGNATURE_TOPICS)


def test_nodes_that_show_up_in_time_are_no_failure():
    watch = DiscoveryWatch(REMOTE, first_seen_s=10.0)
    assert watch.update(0.0, LOCAL) is None
    assert watch.update(6.0, ALL) is None
    assert watch.update(500.0, ALL) is None and watch.report is None


def test_a_node_never_seen_is_named_once_the_first_seconds_are_up():
    watch = DiscoveryWatch(REMOTE, first_seen_s=10.0)
    partial = GraphView(LOCAL.nodes | {"sim", "detector"}, LOCAL.published)
    assert watch.update(100.0, partial) is None
    assert watch.update(109.9, partial) is None
    report = watch.update(110.0, partial)
    assert report is not None and report.startswith("cannot see nodes arm, gripper")
    assert "10 s after the start" in report
    assert watch.update(111.0, partial) is None  # reported once
    assert watch.report == report


def test_a_node_whose_topic_has_a_publisher_counts_as_seen_before_its_name_arrives():
    """Under load the names (ROS's node-info topic) lag the endpoints by seconds."""
    watch = DiscoveryWatch(("sim", "arm"), first_seen_s=5.0)
    endpoints_only = GraphView(LOCAL.nodes, LOCAL.published | {"/sim/ground_truth",
                                                               "/arm/status"})
    assert watch.topics == ["/sim/ground_truth", "/arm/status"]
    assert watch.update(0.0, endpoints_only) is None
    assert watch.update(6.0, endpoints_only) is None


def test_a_node_gone_longer_than_a_respawn_is_lost_and_one_back_in_time_is_not():
    watch = DiscoveryWatch(("arm",), first_seen_s=10.0, lost_after_s=45.0)
    with_arm = GraphView(frozenset({"arm"}))
    assert watch.update(0.0, with_arm) is None
    assert watch.update(30.0, GraphView()) is None  # respawning on its computer
    assert watch.update(40.0, with_arm) is None
    assert watch.update(84.0, GraphView()) is None
    report = watch.update(85.0, GraphView())
    assert report == "lost node arm (expected on another computer): not seen for 45 s"


def test_ports_follow_the_rtps_rules_for_the_domain():
    assert discovery_ports(0, participants=4) == "7400-7401 (multicast) and 7410-7417 (unicast)"
    assert discovery_ports(72, participants=1).startswith("25400-25401 (multicast) and 25410-")


def test_the_hint_names_the_settings_that_keep_discovery_on_this_computer():
    local = discovery_hint({"ROS_DOMAIN_ID": "7", "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert "ROS_DOMAIN_ID=7" in local and "LOCALHOST without static peers" in local
    assert "9150-9151 (multicast)" in local
    peers = discovery_hint({"ROS_AUTOMATIC_DISCOVERY_RANGE": "localhost",
                            "ROS_STATIC_PEERS": "10.0.0.2"})
    assert "ROS_STATIC_PEERS=10.0.0.2" in peers and "stays on this computer" not in peers
    assert "OFF finds nothing" in discovery_hint({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"})
    assert "ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET" in discovery_hint({})


class FakeGraphNode:
    """rclpy's graph calls, answered from fixed lists."""

    def __init__(self, names, publishers):
        self.names, self.publishers, self.asked = names, publishers, []

    def get_node_names_and_namespaces(self):
        return [(n, "/") for n in self.names]

    def count_publishers(self, topic):
        self.asked.append(topic)
        return self.publishers.get(topic, 0)


def test_the_graph_view_asks_only_for_the_topics_watched():
    node = FakeGraphNode(["planner", "sim"], {"/arm/status": 1, "/plan": 1})
    view = graph_view(node, ["/arm/status", "/gripper/status"])
    assert view == GraphView(frozenset({"planner", "sim"}), frozenset({"/arm/status"}))
    assert node.asked == ["/arm/status", "/gripper/status"]


def test_a_node_heard_steadily_that_falls_silent_is_cut_off_long_before_its_lease_ends():
    watch = DiscoveryWatch(("sim", "arm"), silent_after_s=5.0)
    assert watch.update(0.0, ALL, {"sim": None}) is None
    assert watch.update(1.0, ALL, {"sim": 1.0}) is None
    assert watch.update(5.9, ALL, {"sim": 1.0}) is None  # the graph still lists it
    report = watch.update(6.0, ALL, {"sim": 1.0})
    assert report == ("no data from node sim (expected on another computer) for 5 s: the link "
                      "to its computer is down, or it hangs")


def test_a_node_seen_whose_data_never_arrives_is_named():
    watch = DiscoveryWatch(("sim",), first_seen_s=10.0, silent_after_s=5.0)
    assert watch.update(0.0, LOCAL, {"sim": None}) is None  # not seen yet: no data expected
    assert watch.update(3.0, ALL, {"sim": None}) is None
    report = watch.update(8.0, ALL, {"sim": None})
    assert report is not None and report.startswith("sees node sim")
    assert "data ports are blocked" in report


def test_data_of_a_node_run_here_is_not_watched():
    watch = DiscoveryWatch(("arm",), silent_after_s=5.0)
    assert watch.update(0.0, ALL, {"sim": 0.0}) is None
    assert watch.update(60.0, ALL, {"sim": 0.0}) is None
