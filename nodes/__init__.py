"""densepack's ROS 2 nodes: one subpackage per node (pure logic + a thin ``node.py``)."""
