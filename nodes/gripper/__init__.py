"""The gripper node: the executor's gap commands to the Robotiq 2F-85 driver's knuckle
joint, and a grasp signal from the knuckle alone."""
