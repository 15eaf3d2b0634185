"""Session-wide test set-up: a private ROS_DOMAIN_ID and the in-process ROS harness."""

from __future__ import annotations

import os
import tempfile

import pytest
from hypothesis import HealthCheck, settings

# A loaded 2-core machine makes per-example deadlines and speed checks flaky, not informative.
settings.register_profile(
    "densepack", deadline=None, suppress_health_check=[HealthCheck.too_slow], max_examples=60
)
settings.load_profile("densepack")


def pytest_configure(config: pytest.Config) -> None:
    # Before anything imports rclpy: this session's own DDS domain, discovery kept on this
    # host, so parallel runs (and a cell a developer left running) never hear each other.
    from nodes.common.harness import allocate_domain_id

    # each pytest-xdist worker its own (a worker inherits the controller's environment)
    if "DENSEPACK_TEST_DOMAIN" not in os.environ or "PYTEST_XDIST_WORKER" in os.environ:
        os.environ["DENSEPACK_TEST_DOMAIN"] = str(allocate_domain_id())
    os.environ["ROS_DOMAIN_ID"] = os.environ["DENSEPACK_TEST_DOMAIN"]
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    # Runtime state (ROS logs, the detector's camera check record) in this session's own
    # folder: no test reads what a developer's cell or another test session left behind.
    if "DENSEPACK_TEST_ROS_HOME" not in os.environ:
        os.environ["DENSEPACK_TEST_ROS_HOME"] = tempfile.mkdtemp(prefix="densepack-ros-home-")
    os.environ["ROS_HOME"] = os.environ["DENSEPACK_TEST_ROS_HOME"]
    os.environ.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")


@pytest.fixture
def ros():
    """A ``RosHarness``: private Context on this session's domain, spun in a thread."""
    from nodes.common.harness import RosHarness

    harness = RosHarness(domain_id=int(os.environ["ROS_DOMAIN_ID"]))
    try:
        yield harness
        harness.check()
    finally:
        harness.shutdown()
