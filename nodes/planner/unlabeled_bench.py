"""Unlabeled benchmark: k random blocks -> a k-slot grid any block may fill (paper Fig. 2).

For each k in --k, plans --seeds random scenes (``nodes.common.scenes`` scatter, same seeds
and workspace as ``random_scene``; the goal grid is the most nearly square rows x cols = k,
so 3 and 8 blocks get 1x3 and 2x4 grids; a seed whose blocks do not fit the workspace at
that density is left out and listed) with: the pebble-graph planner for each b in --b,
the baseline (min-cost assignment + labeled pIRS) and the labeled pIRS planner on the same
blocks with the labeled grid goal. Reports success rate, planning time (median, p90),
actions (median) before and after smoothing, actions / lower bound and, for the unlabeled
planners, the median per-scene difference to the labeled planner's actions. Every plan
counted has passed the replay validator.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
from typing import Any

import numpy as np

from msgs_py import Goal, GridSpec, Scene
from nodes.common.scenes import BLOCK_SIZE, scatter_blocks, workspace_for
from nodes.planner.config import PlannerConfig
from nodes.planner.planner import PlanOutcome, plan_scene
from nodes.planner.unlabeled.baseline import plan_assignment
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.planner import plan_unlabeled

COLUMNS = ["n_blocks", "grid", "density", "planner", "b", "seeds", "success_rate",
           "time_median_s", "time_p90_s", "actions_raw_median", "actions_median",
           "actions_over_lower_bound_median", "pushes_median", "actions_minus_labeled_median"]

K_DEFAULT = (2, 3, 4, 6, 8, 9, 16)
B_DEFAULT = (1, 2, 3, 4)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--k", type=int, nargs="+", default=None,
                        help=f"block counts (default {' '.join(map(str, K_DEFAULT))}; "
                        "--quick: 4 9)")
    parser.add_argument("--b", type=int, nargs="+", default=None,
                        help="empty nodes per pebble graph (default 1 2 3 4; --quick: 1 2)")
    parser.add_argument("--density", type=float, default=0.20,
                        help="block area / workspace area (default 0.20, the planner "
                        "benchmark's 'high')")
    parser.add_argument("--budget", type=float, default=60.0, help="planning budget per scene, s")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--no-baselines", action="store_true",
                        help="only the pebble-graph planner (no assignment, no labeled rows)")


def grid_shape(k: int) -> tuple[int, int]:
    """The most nearly square rows x cols = k (rows <= cols)."""
    rows = max(r for r in range(1, math.isqrt(k) + 1) if k % r == 0)
    return rows, k // rows


def bench_scene(k: int, density: float, seed: int, labeled: bool) -> Scene:
    """Blocks as ``random_scene(k, density, seed)`` scatters them, goal a rows x cols grid."""
    workspace = workspace_for(k, density)
    blocks = scatter_blocks(k, workspace, np.random.default_rng(seed), BLOCK_SIZE, 0.002)
    rows, cols = grid_shape(k)
    goal = Goal(grid=GridSpec(rows, cols, workspace.center, 0.0, 0.003), labeled=labeled)
    return Scene(workspace, BLOCK_SIZE, blocks, goal)


def _percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def _median(values: list[float]) -> float:
    return float(statistics.median(values)) if values else float("nan")


@dataclasses.dataclass
class _Tally:
    times: list[float] = dataclasses.field(default_factory=list)
    actions: dict[int, float] = dataclasses.field(default_factory=dict)  # seed -> actions
    raw: list[float] = dataclasses.field(default_factory=list)
    ratio: list[float] = dataclasses.field(default_factory=list)
    pushes: list[float] = dataclasses.field(default_factory=list)
    failures: list[dict[str, Any]] = dataclasses.field(default_factory=list)

    def add(self, seed: int, out: PlanOutcome) -> None:
        self.times.append(out.planning_time_s)
        if out.plan is None:
            self.failures.append({"seed": seed, "error": out.error})
            return
        n = len(out.plan.actions)
        self.actions[seed] = float(n)
        self.raw.append(out.metrics.get("actions_raw", float(n)))
        self.ratio.append(n / max(out.lower_bound, 1))
        self.pushes.append(float(sum(a.type == "push" for a in out.plan.actions)))

    def row(self, k: int, density: float, planner: str, b: Any, seeds: int,
            labeled: _Tally | None) -> dict[str, Any]:
        rows, cols = grid_shape(k)
        diffs = ([self.actions[s] - labeled.actions[s] for s in self.actions
                  if s in labeled.actions] if labeled is not None else [])
        return {
            "n_blocks": k, "grid": f"{rows}x{cols}", "density": density, "planner": planner,
            "b": b, "seeds": seeds, "success_rate": len(self.actions) / seeds,
            "time_median_s": _median(self.times), "time_p90_s": _percentile(self.times, 90),
            "actions_raw_median": _median(self.raw),
            "actions_median": _median(list(self.actions.values())),
            "actions_over_lower_bound_median": _median(self.ratio),
            "pushes_median": _median(self.pushes),
            "actions_minus_labeled_median": _median(diffs),
            "failures": self.failures,
        }


def run(opts: argparse.Namespace) -> list[dict[str, Any]]:
    ks = opts.k or ([4, 9] if opts.quick else list(K_DEFAULT))
    bs = opts.b or ([1, 2] if opts.quick else list(B_DEFAULT))
    n_seeds = opts.seeds or (3 if opts.quick else 10)
    seeds = range(opts.first_seed, opts.first_seed + n_seeds)
    rows: list[dict[str, Any]] = []
    for k in ks:
        config = PlannerConfig(budget_s=opts.budget)
        labeled, baseline = _Tally(), _Tally()
        pebble = {b: _Tally() for b in bs}
        skipped = []
        for seed in seeds:
            cfg = dataclasses.replace(config, seed=seed)
            try:
                scene = bench_scene(k, opts.density, seed, labeled=False)
            except RuntimeError:  # the blocks do not fit at this density: no instance
                skipped.append(seed)
                continue
            for b in bs:
                pebble[b].add(seed, plan_unlabeled(scene, cfg, UnlabeledConfig(b=b)))
            if not opts.no_baselines:
                baseline.add(seed, plan_assignment(scene, cfg, UnlabeledConfig()))
                labeled.add(seed, plan_scene(bench_scene(k, opts.density, seed, True), cfg))
        ref = None if opts.no_baselines else labeled
        n = n_seeds - len(skipped)
        if n == 0:
            continue
        new = []
        if not opts.no_baselines:
            new.append(labeled.row(k, opts.density, "labeled_pirs", "-", n, None))
            new.append(baseline.row(k, opts.density, "assignment_pirs", "-", n, ref))
        new += [pebble[b].row(k, opts.density, "pebble_graphs", b, n, ref) for b in bs]
        for row in new:
            row["seeds_without_scene"] = skipped
        rows += new
    return rows
