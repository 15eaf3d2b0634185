"""Benchmarks of the planners (``densepack-bench planner`` / ``unlabeled``) and their seeded
scene sets."""
