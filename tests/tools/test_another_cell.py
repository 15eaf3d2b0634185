"""densepack-run refuses to start a second cell on a domain where one already runs."""

from __future__ import annotations

import pytest
from densepack_interfaces.msg import ExecutorStatus

from nodes.cell.monitor import another_cell
from nodes.common.qos import LATCHED

pytestmark = pytest.mark.ros


def test_a_cell_on_the_domain_is_found_by_the_topics_only_a_cell_publishes(ros):
    assert another_cell(ros.probe, wait_s=0.5) is None
    ros.publisher("/executor/status", ExecutorStatus, LATCHED)
    assert another_cell(ros.probe, wait_s=5.0) == "/executor/status"
