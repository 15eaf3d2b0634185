"""``densepack-plan SCENE.yaml -o plan.json --png plan.png``: plan a scene file offline.

Parameters come from ``config/planner.yaml`` (or ``--params``), then the flags. The plan is
validated by the replay validator before it is written; on failure the command prints the
failing block and the reason and exits 1 (the PNG, if asked for, still shows the scene).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from msgs_py import MessageError, load_scene, save_plan
from nodes.common.paths import config_path
from nodes.planner.config import PlannerConfig
from nodes.planner.planner import plan_scene


def load_config(path: str | Path | None, overrides: dict[str, Any]) -> PlannerConfig:
    """``PlannerConfig`` from a ROS params file (``/**: ros__parameters:``) plus overrides."""
    values: dict[str, Any] = {}
    file = config_path(path or "planner.yaml")
    if file.exists():
        data = yaml.safe_load(file.read_text()) or {}
        for section in data.values():
            if isinstance(section, dict):
                values.update(section.get("ros__parameters", {}))
    elif path is not None:
        raise FileNotFoundError(f"no parameter file {file}")
    names = {f.name for f in dataclasses.fields(PlannerConfig)}
    values = {k: v for k, v in values.items() if k in names}
    values.update({k: v for k, v in overrides.items() if v is not None})
    return PlannerConfig(**values)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="densepack-plan", description=__doc__.splitlines()[0])
    p.add_argument("scene", type=Path, help="scene file (YAML/JSON) with blocks and a goal")
    p.add_argument("-o", "--output", type=Path, default=None, help="plan JSON to write")
    p.add_argument("--png", type=Path, default=None, help="drawing of the plan to write")
    p.add_argument("--params", default=None, help="planner parameter file (config/planner.yaml)")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--budget", dest="budget_s", type=float, default=None, help="time budget, s")
    p.add_argument("--n-samples", type=int, default=None)
    p.add_argument("--eps", type=float, default=None)
    for name in ("a1", "a2", "a3"):
        p.add_argument(f"--{name}", type=float, default=None)
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="any other planner parameter (YAML value), repeatable")
    return p


def main(args: Sequence[str] | None = None) -> int:
    opts = _parser().parse_args(args)
    overrides = {k: getattr(opts, k) for k in ("seed", "budget_s", "n_samples", "eps", "a1",
                                                 "a2", "a3")}
    for item in opts.set:
        name, _, value = item.partition("=")
        overrides[name.strip()] = yaml.safe_load(value)
    try:
        config = load_config(opts.params, overrides)
        scene = load_scene(opts.scene)
        outcome = plan_scene(scene, config)
    except (MessageError, ValueError, TypeError, FileNotFoundError) as err:
        print(f"densepack-plan: {err}", file=sys.stderr)
        return 2
    if opts.png is not None:
        from nodes.planner.draw import draw_plan

        draw_plan(scene, outcome.plan, opts.png)
    if not outcome.ok:
        print(f"densepack-plan: no plan ({outcome.planning_time_s:.2f} s): {outcome.error}",
              file=sys.stderr)
        return 1
    plan = outcome.plan
    n_push = sum(a.type == "push" for a in plan.actions)
    print(f"plan {plan.plan_id}: {len(plan.actions)} actions ({n_push} pushes, lower bound "
          f"{outcome.lower_bound}) in {outcome.planning_time_s:.2f} s, validated")
    if opts.output is not None:
        save_plan(plan, opts.output)
        print(f"wrote {opts.output}")
    if opts.png is not None:
        print(f"wrote {opts.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
