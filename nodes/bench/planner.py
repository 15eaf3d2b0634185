"""Planner benchmark: labeled scenes -> dense grid (gap 3 mm), per set, block count, density.

For each instance set in --set (``instances``: random, enclosed, rotated, permuted), block
count and density, plans ``--seeds`` scenes with pIRS and reports success rate, planning time
(median, p90), actions, the certified lower bound (``bound``) and the gap to it, and, for up to
``exact.MAX_BLOCKS`` blocks, the exact optimum over a fixed pose set and the gap to that. Every
plan counted has passed the replay validator; a scene that fails, or cannot be built, is
listed with its reason in the row's ``failures`` (never a traceback). ``--variants`` adds
rows with one option switched off (or on) to measure each. Scenes in the reference file
(``reference_file``, written by ``densepack-bench reference``) add the gap to the best plan
known and, where it is proven, to the optimum (``scenes_proven``, ``scenes_at_optimum``).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
from collections.abc import Callable
from typing import Any

import numpy as np

from msgs_py import Pose2D, Scene
from nodes.bench.instances import SETS, instance
from nodes.bench.reference_file import load_reference, proven_optimum, scene_key
from nodes.planner.bounds.exact import MAX_BLOCKS, ExactLimit, exact_plan
from nodes.planner.cli import name_value
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.labeled.plan_labeled import plan_scene
from nodes.planner.outcome import PlanOutcome

COLUMNS = ["set", "n_blocks", "density", "variant", "seeds", "success_rate", "time_median_s",
           "time_p90_s", "actions_median", "lower_bound_median",
           "actions_minus_lower_bound_median", "scenes_within_lower_bound_plus_1",
           "actions_over_lower_bound_median",
           "exact_median", "actions_minus_exact_median", "reference_scenes",
           "actions_minus_best_known_median", "scenes_proven", "actions_minus_optimum_median",
           "scenes_at_optimum"]

DENSITIES = {"low": 0.05, "high": 0.20, "cramped": 0.30}
#: (block counts, densities) per set when --n / --density are not given; --quick: the first.
DEFAULTS = {
    "random": [((4, 9, 16, 25), ("low", "high")), ((4, 9, 16), ("cramped",))],
    "enclosed": [((9, 16, 25), ("high",))],
    "rotated": [((4, 9, 16), ("high", "cramped"))],
    "permuted": [((4, 9), ("high",))],
}
QUICK = {"random": [((4, 9), ("low", "high"))], "enclosed": [((9,), ("high",))],
         "rotated": [((4,), ("high",))], "permuted": [((4,), ("high",))]}
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


def density_value(text: str) -> float:
    """A density by name (low, high, cramped) or as a number."""
    if text in DENSITIES:
        return DENSITIES[text]
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"density must be one of {sorted(DENSITIES)} or a number, got {text!r}") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--set", dest="sets", nargs="+", choices=SETS, default=None,
                        help="instance sets (default: all)")
    parser.add_argument("--n", type=int, nargs="+", default=None,
                        help="block counts (default per set, e.g. random: 4 9 16 25)")
    parser.add_argument("--density", type=density_value, nargs="+", default=None,
                        help="densities: low 0.05, high 0.20, cramped 0.30, or numbers")
    parser.add_argument("--budget", type=float, default=60.0, help="planning budget per scene, s")
    parser.add_argument("--variants", nargs="+", choices=sorted(VARIANTS), default=["default"],
                        help="option sets to run (default: the configured defaults)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--no-exact", action="store_true",
                        help=f"skip the exact search (done for <= {MAX_BLOCKS} blocks)")
    for f in dataclasses.fields(PlannerConfig):
        if f.type in ("bool", bool):
            parser.add_argument(f"--{f.name.replace('_', '-')}", choices=["on", "off"],
                                default=None, help=f"override option {f.name}")
    parser.add_argument("--param", dest="params", action="append", default=[],
                        type=param_value, metavar="NAME=VALUE",
                        help="override any planner parameter (config/planner.yaml), e.g. "
                             "improve_max_s=30; repeatable")


def param_value(text: str) -> tuple[str, Any]:
    """``NAME=VALUE`` for ``--param``: a PlannerConfig field and its value (YAML-typed)."""
    name, value = name_value(text)
    if "=" not in text or name not in {f.name for f in dataclasses.fields(PlannerConfig)}:
        raise argparse.ArgumentTypeError(
            f"--param takes NAME=VALUE with NAME a planner parameter, got {text!r}")
    return name, value


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def median(values: list[float]) -> float:
    return float(statistics.median(values)) if values else float("nan")


def scene_assignment(scene: Scene) -> tuple[list[Pose2D], dict[int, int] | None]:
    """The goal's slots and, for a labeled goal, block id -> slot index (the form the exact
    search and the decision procedure take)."""
    slots = scene.goal.slot_poses(scene.block_size)
    if not scene.goal.labeled:
        return slots, None
    index = {(p.x, p.y): k for k, p in enumerate(slots)}
    return slots, {b: index[(p.x, p.y)] for b, p in scene.goal_assignment().items()}


def exact_actions(scene: Scene, config: PlannerConfig) -> int | None:
    """The exact optimum over the fixed pose set, or None (too big, not proven)."""
    if len(scene.blocks) > MAX_BLOCKS or scene.goal.yaw_exact:
        return None
    ctx = PlanContext.for_scene(scene, config)
    slots, assignment = scene_assignment(scene)
    try:
        return len(exact_plan(ctx, {b.id: b.pose for b in scene.blocks}, slots,
                              assignment).actions)
    except ExactLimit:
        return None


@dataclasses.dataclass
class Tally:
    """Per-seed figures of one planner on one instance set."""

    times: list[float] = dataclasses.field(default_factory=list)
    actions: dict[int, float] = dataclasses.field(default_factory=dict)  # seed -> actions
    bounds: dict[int, float] = dataclasses.field(default_factory=dict)
    exact: dict[int, float] = dataclasses.field(default_factory=dict)
    best_known: dict[int, float] = dataclasses.field(default_factory=dict)  # reference file
    optimum: dict[int, float] = dataclasses.field(default_factory=dict)  # ... when proven
    raw: list[float] = dataclasses.field(default_factory=list)
    pushes: list[float] = dataclasses.field(default_factory=list)
    clears: list[float] = dataclasses.field(default_factory=list)
    failures: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    seeds: int = 0

    def add(self, seed: int, out: PlanOutcome) -> None:
        self.seeds += 1
        self.times.append(out.planning_time_s)
        self.bounds[seed] = float(out.lower_bound)
        if out.plan is None:
            self.failures.append({"seed": seed, "error": out.error})
            return
        n = float(len(out.plan.actions))
        self.actions[seed] = n
        self.raw.append(out.metrics.get("actions_raw", n))
        self.pushes.append(float(sum(a.type == "push" for a in out.plan.actions)))
        self.clears.append(out.metrics.get("clears", 0.0))

    def refuse(self, seed: int, error: str) -> None:
        """A scene that could not be planned at all (bad input, no instance)."""
        self.seeds += 1
        self.failures.append({"seed": seed, "error": error})

    def figures(self) -> dict[str, Any]:
        done = sorted(self.actions)
        gap = [self.actions[s] - self.bounds[s] for s in done]
        ratio = [self.actions[s] / max(self.bounds[s], 1.0) for s in done]
        to_exact = [self.actions[s] - self.exact[s] for s in done if s in self.exact]
        to_best = [self.actions[s] - self.best_known[s] for s in done if s in self.best_known]
        to_optimum = [self.actions[s] - self.optimum[s] for s in done if s in self.optimum]
        return {
            "seeds": self.seeds,
            "success_rate": len(done) / self.seeds if self.seeds else float("nan"),
            "time_median_s": median(self.times), "time_p90_s": percentile(self.times, 90),
            "actions_median": median([self.actions[s] for s in done]),
            "actions_raw_median": median(self.raw),
            "pushes_median": median(self.pushes), "clears_median": median(self.clears),
            "lower_bound_median": median(list(self.bounds.values())),
            "actions_minus_lower_bound_median": median(gap),
            "scenes_within_lower_bound_plus_1": sum(g <= 1 for g in gap),
            "actions_over_lower_bound_median": median(ratio),
            "exact_median": median(list(self.exact.values())),
            "exact_solved": len(self.exact),
            "actions_minus_exact_median": median(to_exact),
            "reference_scenes": len(self.best_known),
            "actions_minus_best_known_median": median(to_best),
            "scenes_proven": len(self.optimum),
            "optimum_median": median(list(self.optimum.values())),
            "actions_minus_optimum_median": median(to_optimum),
            "scenes_at_optimum": sum(g <= 0 for g in to_optimum),
            "failures": self.failures,
            "per_seed": {str(s): {"actions": self.actions.get(s), "lower_bound": b,
                                  "exact": self.exact.get(s),
                                  "best_known": self.best_known.get(s),
                                  "optimum": self.optimum.get(s)}
                         for s, b in self.bounds.items()},
        }


def plan_safely(tally: Tally, seed: int, planner: Callable[..., PlanOutcome], *args) -> None:
    """``planner(*args)`` into ``tally``; input it refuses becomes a failure with the reason."""
    try:
        tally.add(seed, planner(*args))
    except (ValueError, RuntimeError) as err:  # MessageError is a ValueError
        tally.refuse(seed, f"{type(err).__name__}: {err}")


def run_set(kind: str, n: int, density: float, seeds: range, config: PlannerConfig,
            exact: bool = True) -> dict[str, Any]:
    tally = Tally()
    reference = load_reference()
    for seed in seeds:
        entry = reference.get(scene_key(kind, n, density, seed))
        if entry is not None and entry.get("best_actions") is not None:
            tally.best_known[seed] = float(entry["best_actions"])
            if proven_optimum(entry) is not None:
                tally.optimum[seed] = float(proven_optimum(entry))
        try:
            scene = instance(kind, n, density, seed)
        except (ValueError, RuntimeError) as err:
            tally.refuse(seed, f"no instance: {err}")
            continue
        plan_safely(tally, seed, plan_scene, scene, dataclasses.replace(config, seed=seed))
        if exact:
            best = exact_actions(scene, config)
            if best is not None:
                tally.exact[seed] = float(best)
    return {"set": kind, "n_blocks": n, "density": density, "budget_s": config.budget_s,
            **tally.figures()}


def sizes(opts: argparse.Namespace, kind: str) -> list[tuple[int, float]]:
    """(n, density) pairs of set ``kind`` for these options."""
    table = QUICK if opts.quick else DEFAULTS
    pairs = [(n, DENSITIES[d]) for ns, ds in table[kind] for n in ns for d in ds]
    if opts.n is not None:
        pairs = [(n, d) for n in opts.n for d in dict.fromkeys(d for _, d in pairs)]
    if opts.density is not None:
        pairs = [(n, d) for n in dict.fromkeys(n for n, _ in pairs) for d in opts.density]
    return pairs


def run(opts: argparse.Namespace) -> list[dict[str, Any]]:
    n_seeds = opts.seeds or (5 if opts.quick else 20)
    seeds = range(opts.first_seed, opts.first_seed + n_seeds)
    overrides = {**dict(getattr(opts, "params", [])),
                 **{f.name: getattr(opts, f.name) == "on" for f in dataclasses.fields(PlannerConfig)
                    if getattr(opts, f.name, None) is not None}}
    rows = []
    for variant in opts.variants:
        try:
            config = PlannerConfig(budget_s=opts.budget, **{**VARIANTS[variant], **overrides})
        except (TypeError, ValueError) as err:
            raise SystemExit(f"densepack-bench planner: {err}") from None
        for kind in opts.sets or SETS:
            for n, density in sizes(opts, kind):
                row = run_set(kind, n, density, seeds, config, not opts.no_exact)
                row["variant"] = variant
                row["overrides"] = overrides
                rows.append(row)
                print(f"  {variant} {kind} n={n} density={density}: success "
                      f"{row['success_rate']:.2f}, median {row['time_median_s']:.2f} s, "
                      f"actions {row['actions_median']} (lower bound "
                      f"{row['lower_bound_median']})", flush=True)
    return rows
