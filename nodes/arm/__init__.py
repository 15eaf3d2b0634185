"""The arm node: Cartesian tool setpoints to ur_robot_driver's joint commands (IK, servo-style
playback, the driver's state, the protective stop unlock)."""
