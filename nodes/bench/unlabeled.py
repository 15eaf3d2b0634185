"""Unlabeled benchmark: k blocks -> a k-slot grid any block may fill (paper Fig. 2), per set.

For each instance set in --set (``instances``: random, enclosed, rotated, permuted), k and
density, plans --seeds scenes (the same blocks as the planner benchmark; a seed whose blocks
do not fit is listed) with: the default method (the portfolio of the two below), the
pebble-graph planner for each b in --b, the baseline
(min-cost assignment + labeled pIRS) and the labeled pIRS planner on the same blocks with
the labeled grid goal. Reports success rate, planning time (median, p90), actions before and
after smoothing, pushes, the certified lower bound and the gap to it, for k <= 5 the exact
optimum over a fixed pose set and the gap to it, and for the unlabeled planners the median
per-scene difference to the labeled planner's actions. Every plan counted has passed the
replay validator; failures are listed with their reason. ``--goal poses`` gives the same
slots as explicit poses instead of a grid.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from msgs_py import Goal, GoalSlot, Scene
from nodes.bench.instances import SETS, grid_shape, instance
from nodes.bench.planner import (
    DENSITIES,
    Tally,
    density_value,
    exact_actions,
    median,
    plan_safely,
)
from nodes.planner.config import PlannerConfig
from nodes.planner.labeled.plan_labeled import plan_scene
from nodes.planner.unlabeled.baseline import plan_assignment
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.plan_unlabeled import plan_unlabeled
from nodes.planner.unlabeled.portfolio import plan_portfolio

COLUMNS = ["set", "n_blocks", "grid", "goal", "density", "planner", "b", "seeds", "success_rate",
           "time_median_s", "time_p90_s", "actions_raw_median", "actions_median",
           "lower_bound_median", "actions_minus_lower_bound_median", "exact_median",
           "actions_minus_exact_median", "pushes_median", "actions_minus_labeled_median"]

GOAL_FORMS = ("grid", "poses")
K_DEFAULT = (2, 3, 4, 6, 8, 9, 16)
B_DEFAULT = (1, 2, 3, 4)
#: (k values, densities, b values) per set when --k / --density / --b are not given.
DEFAULTS = {
    "random": [(K_DEFAULT, ("high",), B_DEFAULT), ((9, 16), ("cramped",), (1,))],
    "enclosed": [((9, 16), ("high",), (1,))],
    "rotated": [((4, 9), ("high", "cramped"), (1,))],
    "permuted": [((4, 9), ("high",), (1,))],
}
QUICK = {"random": [((4, 9), ("high",), (1, 2))], "enclosed": [((9,), ("high",), (1,))],
         "rotated": [((4,), ("high",), (1,))], "permuted": [((4,), ("high",), (1,))]}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--set", dest="sets", nargs="+", choices=SETS, default=None,
                        help="instance sets (default: all)")
    parser.add_argument("--k", type=int, nargs="+", default=None,
                        help=f"block counts (default per set, random: "
                        f"{' '.join(map(str, K_DEFAULT))})")
    parser.add_argument("--b", type=int, nargs="+", default=None,
                        help="empty nodes per pebble graph (default per set, random: 1 2 3 4)")
    parser.add_argument("--density", type=density_value, nargs="+", default=None,
                        help="densities: low 0.05, high 0.20, cramped 0.30, or numbers")
    parser.add_argument("--budget", type=float, default=60.0, help="planning budget per scene, s")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--no-baselines", action="store_true",
                        help="only the pebble-graph planner (no assignment, no labeled rows)")
    parser.add_argument("--no-exact", action="store_true", help="skip the exact search")
    parser.add_argument("--goal", dest="goal_forms", nargs="+", choices=GOAL_FORMS,
                        default=["grid"], help="how the unlabeled goal is given: a grid, or "
                        "the same slots as explicit poses (default: grid)")


def bench_scene(k: int, density: float, seed: int, labeled: bool, kind: str = "random",
                goal_form: str = "grid") -> Scene:
    """The scene of set ``kind`` (``instances.instance``); with ``goal_form`` "poses" the
    unlabeled goal lists the grid's slots as explicit poses."""
    scene = instance(kind, k, density, seed, labeled)
    if goal_form == "grid" or labeled:
        return scene
    slots = scene.goal.slot_poses(scene.block_size)
    return scene.with_goal(Goal(slots=tuple(GoalSlot(p.x, p.y, p.theta) for p in slots),
                                labeled=False))


def _row(tally: Tally, kind: str, k: int, density: float, planner: str, b: Any,
         labeled: Tally | None, goal_form: str = "grid") -> dict[str, Any]:
    rows, cols = grid_shape(k)
    diffs = ([tally.actions[s] - labeled.actions[s] for s in tally.actions
              if s in labeled.actions] if labeled is not None else [])
    return {"set": kind, "n_blocks": k, "grid": f"{rows}x{cols}", "goal": goal_form,
            "density": density, "planner": planner, "b": b, **tally.figures(),
            "actions_minus_labeled_median": median(diffs)}


def run_set(kind: str, k: int, density: float, bs: list[int], seeds: range,
            opts: argparse.Namespace, goal_form: str = "grid") -> list[dict[str, Any]]:
    config = PlannerConfig(budget_s=opts.budget)
    labeled, baseline, default = Tally(), Tally(), Tally()
    pebble = {b: Tally() for b in bs}
    exact = not getattr(opts, "no_exact", False)
    for seed in seeds:
        cfg = dataclasses.replace(config, seed=seed)
        try:
            scene = bench_scene(k, density, seed, False, kind, goal_form)
            lab_scene = bench_scene(k, density, seed, True, kind)
        except (ValueError, RuntimeError) as err:
            for tally in (labeled, baseline, default, *pebble.values()):
                tally.refuse(seed, f"no instance: {err}")
            continue
        best = exact_actions(scene, cfg) if exact else None
        plan_safely(default, seed, plan_portfolio, scene, cfg, UnlabeledConfig())
        for b in bs:
            plan_safely(pebble[b], seed, plan_unlabeled, scene, cfg, UnlabeledConfig(b=b))
        if not opts.no_baselines:
            plan_safely(baseline, seed, plan_assignment, scene, cfg, UnlabeledConfig())
            plan_safely(labeled, seed, plan_scene, lab_scene, cfg)
            lab_best = exact_actions(lab_scene, cfg) if exact else None
            if lab_best is not None:
                labeled.exact[seed] = float(lab_best)
        if best is not None:
            for tally in (baseline, default, *pebble.values()):
                tally.exact[seed] = float(best)
    ref = None if opts.no_baselines else labeled
    out = [_row(default, kind, k, density, "default (portfolio)", "1", ref, goal_form)]
    if not opts.no_baselines:
        out.append(_row(labeled, kind, k, density, "labeled_pirs", "-", None, goal_form))
        out.append(_row(baseline, kind, k, density, "assignment_pirs", "-", ref, goal_form))
    out += [_row(pebble[b], kind, k, density, "pebble_graphs", b, ref, goal_form) for b in bs]
    return out


def sizes(opts: argparse.Namespace, kind: str) -> list[tuple[int, float, list[int]]]:
    """(k, density, b values) of set ``kind`` for these options."""
    table = QUICK if opts.quick else DEFAULTS
    out = []
    for ks, ds, bs in table[kind]:
        for k in opts.k or ks:
            for d in opts.density or [DENSITIES[x] for x in ds]:
                out.append((k, d, list(opts.b or bs)))
    return list({(k, d): (k, d, b) for k, d, b in out}.values())


def run(opts: argparse.Namespace) -> list[dict[str, Any]]:
    n_seeds = opts.seeds or (3 if opts.quick else 10)
    seeds = range(opts.first_seed, opts.first_seed + n_seeds)
    rows: list[dict[str, Any]] = []
    for kind in opts.sets or SETS:
        for k, density, bs in sizes(opts, kind):
            new = [row for form in getattr(opts, "goal_forms", ["grid"])
                   for row in run_set(kind, k, density, bs, seeds, opts, form)]
            rows += new
            for row in new:
                print(f"  {kind} k={k} density={density} {row['planner']} b={row['b']}: "
                      f"success {row['success_rate']:.2f}, actions {row['actions_median']} "
                      f"(lower bound {row['lower_bound_median']})", flush=True)
    return rows
