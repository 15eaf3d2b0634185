"""Benchmarks: suites of ``densepack-bench`` that drive several node packages together."""
