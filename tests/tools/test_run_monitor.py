"""The run monitor serves goal after goal (a soak): what it puts on the graph must not grow
with the goals."""

from __future__ import annotations

import pytest

from nodes.cell.monitor import RunMonitor
from nodes.cell.run import SimStarter

pytestmark = pytest.mark.ros


def test_each_goals_sim_starter_uses_the_monitors_one_service_client(ros):
    monitor = RunMonitor(ros.context)
    try:
        clients = len(list(monitor.node.clients))
        starters = [SimStarter(monitor, {"executor"}) for _ in range(3)]  # three goals' runs
        assert len(list(monitor.node.clients)) == clients
        assert all(s.client is monitor.sim_start for s in starters)
    finally:
        monitor.node.destroy_node()


def test_the_runs_simulated_time_is_taken_at_the_result_not_after_the_settling(ros):
    monitor = RunMonitor(ros.context)
    try:
        monitor.sim_time = 41.0
        assert monitor.run_time == 41.0 and not monitor.settled(0.3)  # no result yet
        monitor.goal_ended()
        monitor.sim_time = 41.2  # the last ground truth still coming
        assert monitor.run_time == 41.0 and not monitor.settled(0.3)
        monitor.sim_time = 43.0
        assert monitor.run_time == 41.0 and monitor.settled(0.3)
        monitor.begin_goal(round(43.0 * 1e9))  # the next goal on the same cell
        assert monitor.run_time == 43.0 and not monitor.settled(0.3)
    finally:
        monitor.node.destroy_node()
