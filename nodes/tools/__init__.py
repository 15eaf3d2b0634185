"""Command-line tools built on rclpy: echo, the cell launcher, the goal publisher, benchmarks."""
