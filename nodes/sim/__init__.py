"""The simulated UR10e cell: PyBullet world, arm controller, camera, event monitor, node."""
