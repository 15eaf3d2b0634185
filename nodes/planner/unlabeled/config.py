"""Parameters of the unlabeled (pebble-graph) planner, the baseline and retrieval.

Declared on the planner node under the prefix ``unlabeled.`` (``config/planner.yaml`` holds
the same defaults); the gripper geometry, costs, seed and time budget are the planner's own
(``PlannerConfig``), shared by every goal kind.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from nodes.common.params import param

UNLABELED_METHODS = ("portfolio", "pebble_graphs", "assignment")
RETRIEVAL_METHODS = ("pebble_graphs", "pirs")


@dataclass(frozen=True)
class UnlabeledConfig:
    method: str = param(
        "portfolio", "planner for unlabeled goals: 'portfolio' (both below, the shorter plan "
        "kept), 'pebble_graphs' (rearrangement pebble graphs and their hypergraph) or "
        "'assignment' (min-cost matching of blocks to slots, then the labeled pIRS planner)")
    retrieval_method: str = param(
        "pebble_graphs", "planner for labeled goals that name only some blocks: "
        "'pebble_graphs' (clear the way with unlabeled pebble motion, then move the named "
        "block) or 'pirs' (the labeled planner, unnamed blocks as movable obstacles)")
    b: int = param(1, "b: empty nodes added to the blocks' poses in each rearrangement "
                   "pebble graph (more: better connected graphs, bigger ones)")
    weight: float = param(
        1.5, "weight of the heuristic in the hypergraph A* (1: fewest actions the graphs "
        "allow; more: faster)")
    max_proposals: int = param(4, "rearrangement pebble graphs proposed per hypernode expanded")
    max_expansions: int = param(4000, "hypernodes expanded at most before giving up")
    push_lengths: tuple[float, ...] = param(
        (0.5, 1.0), "lengths of the push into (or out of) a slot through a transient pose, "
        "in block sizes, shortest first")
    smoothing: bool = param(
        True, "re-plan each move for the blocks actually there and merge or drop redundant "
        "moves of a block")

    def __post_init__(self) -> None:
        if self.method not in UNLABELED_METHODS:
            raise ValueError(f"parameter 'unlabeled.method' must be one of {UNLABELED_METHODS}, "
                             f"got {self.method!r}")
        if self.retrieval_method not in RETRIEVAL_METHODS:
            raise ValueError("parameter 'unlabeled.retrieval_method' must be one of "
                             f"{RETRIEVAL_METHODS}, got {self.retrieval_method!r}")
        if self.b < 0 or self.max_proposals < 1 or self.max_expansions < 1:
            raise ValueError("parameters 'unlabeled.b' >= 0, 'unlabeled.max_proposals' and "
                             "'unlabeled.max_expansions' >= 1 are required")
        if self.weight < 1.0:
            raise ValueError(f"parameter 'unlabeled.weight' must be >= 1, got {self.weight}")
        if not self.push_lengths or any(v <= 0.0 for v in self.push_lengths):
            raise ValueError("parameter 'unlabeled.push_lengths' needs positive lengths")

    def to_params(self) -> dict[str, Any]:
        """For a plan's ``params`` (prefixed, like the ROS parameters)."""
        return {f"unlabeled.{f.name}": (list(getattr(self, f.name))
                                        if isinstance(getattr(self, f.name), tuple)
                                        else getattr(self, f.name)) for f in fields(self)}
