"""``densepack-plan SCENE.yaml -o plan.json --png plan.png``: plan a scene file offline.

Any goal kind: labeled (pIRS), unlabeled (rearrangement pebble graphs, or ``--method
assignment``), retrieval (a labeled goal naming only some blocks).

Parameters come from ``config/planner.yaml`` (or ``--params``), then the flags. The plan is
validated by the replay validator before it is written; on failure the command prints the
failing block and the reason and exits 1 (the PNG, if asked for, still shows the scene).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from msgs_py import MessageError, load_scene, save_plan
from nodes.common.params import configs_from_parameters, read_params_file
from nodes.common.paths import config_path
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import goal_kind, plan_goal
from nodes.planner.geometry.context import planning_workspace
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.robot.reach import ur10e_reach

#: The planner node's parameter groups, as ``--params-file`` names them.
PLANNER_PARAMETERS = (("", PlannerConfig), ("unlabeled.", UnlabeledConfig))


def load_planner_configs(path: str | Path | None, overrides: dict[str, Any]
                         ) -> tuple[PlannerConfig, UnlabeledConfig]:
    """Both parameter groups from a ROS params file (default ``config/planner.yaml``) plus
    ``overrides`` (parameter names; None values are ignored).

    Raises:
        FileNotFoundError: ``path`` given and missing.
        ValueError: an unknown parameter name or a bad value (named).
    """
    file = config_path(path or "planner.yaml")
    values: dict[str, Any] = {}
    if file.exists():
        values = read_params_file(file, node_name="planner")
    elif path is not None:
        raise FileNotFoundError(f"no parameter file {file}")
    given = {k: v for k, v in overrides.items() if v is not None}
    values.update(given)
    source = f"{file}{' and the command line' if given else ''}"
    config, unlabeled = configs_from_parameters(PLANNER_PARAMETERS, values, source)
    return config, unlabeled


def name_value(text: str) -> tuple[str, Any]:
    """``NAME=VALUE`` from the command line: the name, and the value as YAML reads it."""
    name, _, value = text.partition("=")
    return name.strip(), yaml.safe_load(value)


def load_config(path: str | Path | None, overrides: dict[str, Any]) -> PlannerConfig:
    """``PlannerConfig`` from a ROS params file plus overrides (``load_planner_configs``)."""
    return load_planner_configs(path, overrides)[0]


def load_unlabeled_config(path: str | Path | None, overrides: dict[str, Any]
                          ) -> UnlabeledConfig:
    """``UnlabeledConfig`` from the same file plus ``unlabeled.<field>`` overrides."""
    return load_planner_configs(path, overrides)[1]


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
    p.add_argument("--method", default=None, help="unlabeled goals: pebble_graphs | assignment")
    p.add_argument("--b", type=int, default=None,
                   help="unlabeled goals: empty nodes per rearrangement pebble graph")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="any other planner parameter (YAML value), repeatable")
    return p


def _note_clipped(scene) -> None:
    """Say so when the scene's workspace reaches beyond the arm (the planner uses only the
    part within its reach)."""
    reach = ur10e_reach()
    used, clipped = planning_workspace(scene, reach)
    if clipped:
        print(f"densepack-plan: note: workspace reaches beyond the arm ({reach.describe()}); "
              f"planning within x {used.x_min:.2f}..{used.x_max:.2f}, y {used.y_min:.2f}.."
              f"{used.y_max:.2f} m", file=sys.stderr)


def main(args: Sequence[str] | None = None) -> int:
    opts = _parser().parse_args(args)
    overrides = {k: getattr(opts, k) for k in ("seed", "budget_s", "n_samples", "eps", "a1",
                                                 "a2", "a3")}
    overrides.update(name_value(item) for item in opts.set)
    for name, flag in (("unlabeled.method", opts.method), ("unlabeled.b", opts.b)):
        if flag is not None:  # a flag given overrides --set; one not given leaves it be
            overrides[name] = flag
    try:
        config, unlabeled = load_planner_configs(opts.params, overrides)
        scene = load_scene(opts.scene)
        _note_clipped(scene)
        outcome = plan_goal(scene, config, unlabeled)
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
    print(f"plan {plan.plan_id} ({goal_kind(scene)} goal, {plan.planner}): "
          f"{len(plan.actions)} actions ({n_push} pushes, lower bound {outcome.lower_bound}) "
          f"in {outcome.planning_time_s:.2f} s, validated")
    if opts.output is not None:
        save_plan(plan, opts.output)
        print(f"wrote {opts.output}")
    if opts.png is not None:
        print(f"wrote {opts.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
