"""Benchmarks and scripted players that drive several node packages at once (no ROS)."""
