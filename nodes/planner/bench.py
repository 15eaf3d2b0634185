"""Planner benchmark: random start -> dense grid (gap 3 mm), per block count and density.

For each n in --n and density in --density, plans ``--seeds`` random scenes
(``nodes.common.scenes.random_scene``) and reports success rate, planning time (median,
p90), actions (median) and actions / lower bound (median; lower bound = blocks not already on
their goal). Every returned plan has passed the replay validator. ``--variants`` adds rows
with one improvement switched off (or on) to measure each option.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
from typing import Any

import numpy as np

from nodes.common.scenes import random_scene
from nodes.planner.config import PlannerConfig
from nodes.planner.planner import plan_scene

COLUMNS = ["n_blocks", "density", "variant", "seeds", "success_rate", "time_median_s",
           "time_p90_s", "actions_median", "actions_over_lower_bound_median", "clears_median"]

DENSITIES = {"low": 0.05, "high": 0.20}
#: Option toggles benchmarked by --variants: name -> config overrides.
VARIANTS = {
    "default": {},
    "paper": {"distance_cost": False, "clear_outside_path": False, "clear_off_goals": False,
              "clear_goal_first": False, "assembly_order": False, "shortcut": False},
    "no_distance_cost": {"distance_cost": False},
    "no_clear_outside_path": {"clear_outside_path": False},
    "no_clear_off_goals": {"clear_off_goals": False},
    "no_clear_goal_first": {"clear_goal_first": False},
    "no_assembly_order": {"assembly_order": False},
    "no_shortcut": {"shortcut": False},
    "a3_low": {"a3": 0.5},
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--n", type=int, nargs="+", default=None,
                        help="block counts (default 4 9 16 25; --quick: 4 9)")
    parser.add_argument("--density", choices=sorted(DENSITIES), nargs="+",
                        default=["low", "high"], help="densities: low ~5%%, high ~20%%")
    parser.add_argument("--budget", type=float, default=60.0, help="planning budget per scene, s")
    parser.add_argument("--variants", nargs="+", choices=sorted(VARIANTS), default=["default"],
                        help="option sets to run (default: the configured defaults)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--gap", type=float, default=0.003,
                        help="gap between goal grid neighbours, m (3 mm: room for perception "
                        "error, so a block pushed in between two others does not rub them)")
    for f in dataclasses.fields(PlannerConfig):
        if f.type in ("bool", bool):
            parser.add_argument(f"--{f.name.replace('_', '-')}", choices=["on", "off"],
                                default=None, help=f"override option {f.name}")


def _percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def run_set(n: int, density: float, seeds: range, config: PlannerConfig, gap: float = 0.003
            ) -> dict[str, Any]:
    times, actions, ratios, clears, failures = [], [], [], [], []
    for seed in seeds:
        scene = random_scene(n, density, seed, gap=gap)
        out = plan_scene(scene, dataclasses.replace(config, seed=seed))
        times.append(out.planning_time_s)
        if out.ok:
            actions.append(len(out.plan.actions))
            ratios.append(len(out.plan.actions) / max(out.lower_bound, 1))
            clears.append(out.metrics.get("clears", 0.0))
        else:
            failures.append({"seed": seed, "error": out.error})
    med = statistics.median
    return {
        "n_blocks": n, "density": density, "seeds": len(seeds), "budget_s": config.budget_s,
        "success_rate": len(actions) / len(seeds),
        "time_median_s": med(times) if times else float("nan"),
        "time_p90_s": _percentile(times, 90),
        "actions_median": med(actions) if actions else float("nan"),
        "actions_over_lower_bound_median": med(ratios) if ratios else float("nan"),
        "clears_median": med(clears) if clears else float("nan"),
        "failures": failures,
    }


def run(opts: argparse.Namespace) -> list[dict[str, Any]]:
    sizes = opts.n or ([4, 9] if opts.quick else [4, 9, 16, 25])
    n_seeds = opts.seeds or (5 if opts.quick else 20)
    seeds = range(opts.first_seed, opts.first_seed + n_seeds)
    overrides = {f.name: getattr(opts, f.name) == "on" for f in dataclasses.fields(PlannerConfig)
                 if getattr(opts, f.name, None) is not None}
    rows = []
    for variant in opts.variants:
        config = PlannerConfig(budget_s=opts.budget, **{**VARIANTS[variant], **overrides})
        for n in sizes:
            for name in opts.density:
                row = run_set(n, DENSITIES[name], seeds, config, opts.gap)
                row["variant"] = variant
                rows.append(row)
                print(f"  {variant} n={n} {name}: success {row['success_rate']:.2f}, "
                      f"median {row['time_median_s']:.2f} s, ratio "
                      f"{row['actions_over_lower_bound_median']:.2f}", flush=True)
    return rows
