"""Benchmarks: the densepack-bench suites (planners, perception) and their seeded inputs."""
