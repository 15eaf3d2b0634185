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
