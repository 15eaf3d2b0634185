"""The densepack planner: pIRS over a single-block PRM mixing pick-and-place and pushes.

Pure logic (``geometry``, ``roadmap``, ``search``, ``validator``, ``planner``) never imports
rclpy; ``node`` is the thin ROS adapter, ``cli`` the offline ``densepack-plan`` command.
"""
