"""Benchmarks, their seeded scene sets and in-process players: the floor above every node
package (``densepack-bench``)."""
