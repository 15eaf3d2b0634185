"""Rearrangement of interchangeable blocks with rearrangement pebble graphs (issue 7).

Krontiris et al., *Similar Part Rearrangement With Pebble Graphs*: stable poses become the
nodes of rearrangement pebble graphs (RPGs), whose edges are transfers that stay feasible
whichever of the other nodes hold a block; an unlabeled pebble-motion solver decides and
realises arrangements inside one graph; hypernodes (graph, signature) chain graphs that share
an arrangement, from the start arrangement to the goal.

Pure modules, no rclpy: ``pebble_motion`` (the discrete solver), ``rpg`` (graphs, signatures),
``hypergraph`` (the search), ``cell_geometry`` (the work cell's sites), ``cell_transfers``
(its transfers), ``smoothing``,
``plan_unlabeled`` (scene in, validated plan out), ``retrieval``, ``baseline``.
"""
