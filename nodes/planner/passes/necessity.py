"""The last pass over every plan: each action must be needed.

First every action that leaves its block where it was (the cube's 90-degree symmetry unless
``yaw_exact``) goes. Then, from the last action to the first, the plan is tried without each
action: the block's later actions start from where it stood before (a pick-and-place keeps its
finger axis at its end in the world, so it is set down on the same footprint, and may grasp
along either axis at its start; a push must still start on its line; a move that now goes
nowhere, the back of an away-and-back, goes too), and the shortened plan is replayed through
the independent validator from the state before the dropped action; it is kept when valid.
Candidates that cannot be valid (the block's next action is a push off that line; a goal
block that would end off its goal) are not replayed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from msgs_py import BlockPose, PickPlace, Plan, Pose2D, Push, Scene
from msgs_py.actions import Action
from nodes.planner.geometry.context import at_pose, same_pose
from nodes.planner.geometry.transfer import pick_place_between, push_line
from nodes.planner.geometry.validator import validate_plan


def _yaw_exact(scene: Scene) -> bool:
    return scene.goal is not None and scene.goal.yaw_exact


def _rebased(action: Action, current: Pose2D, flip: bool) -> Action | None:
    """``action`` for its block standing at ``current``, or None when no such action
    exists. A pick-and-place keeps its finger axis at ``to`` in the world (so it sets the
    block down on the same footprint with the same fingers) and, with ``flip``, grasps at
    ``current`` along the other axis."""
    if isinstance(action, PickPlace):
        return pick_place_between(action.block, current, action.from_.theta, action.to,
                                  (action.grasp + flip) % 2, action.grasp)
    end = Pose2D(action.to.x, action.to.y, current.theta)
    start = [[current.x, current.y, current.theta]]
    if not push_line(start, [[end.x, end.y, end.theta]])[0][0]:
        return None
    return Push.between(action.block, current, end)


def _without(actions: list[Action], i: int, yaw_exact: bool, flip: bool = False
             ) -> list[Action] | None:
    """``actions`` without action i, the block's later actions rebased (its next one grasped
    along the other axis with ``flip``) and dropped too where that leaves them doing nothing
    (away and back); None if impossible."""
    dropped = actions[i]
    out = list(actions[:i])
    current, first = dropped.from_, True
    for a in actions[i + 1:]:
        if a.block == dropped.block:
            a = _rebased(a, current, flip and first)
            if a is None:
                return None
            first = False
            if same_pose(a.from_, a.to, yaw_exact):
                continue
            current = a.to
        out.append(a)
    return out


def _state_before(scene: Scene, actions: list[Action], i: int) -> dict[int, Pose2D]:
    state = {b.id: b.pose for b in scene.blocks}
    for a in actions[:i]:
        state[a.block] = a.to
    return state


def _ends_on_goal(scene: Scene, params: Mapping[str, Any], actions: list[Action], i: int,
                  candidate: list[Action]) -> bool:
    """Cheap necessary test: the dropped action's block ends on its goal (labeled goals)."""
    block = actions[i].block
    goals = scene.goal_assignment() if scene.goal is not None and scene.goal.labeled else {}
    if block not in goals:
        return True
    final = next((a.to for a in reversed(candidate) if a.block == block), None)
    if final is None:
        final = scene.block(block).pose
    return at_pose(final, goals[block], float(params.get("goal_tolerance_xy", 0.0)),
                   float(params.get("goal_tolerance_yaw", 0.0)), _yaw_exact(scene))


def _valid_from(scene: Scene, params: Mapping[str, Any], state: Mapping[int, Pose2D],
                actions: list[Action]) -> bool:
    """Replay ``actions`` through the validator from ``state``."""
    blocks = tuple(BlockPose(b, p.x, p.y, p.theta) for b, p in sorted(state.items()))
    start = Scene(scene.workspace, scene.block_size, blocks, scene.goal, scene.version)
    return validate_plan(Plan(actions=tuple(actions), params=dict(params), scene=start),
                         first_error=True).ok


def drop_no_ops(scene: Scene, actions: list[Action]) -> list[Action]:
    """``actions`` without those that end where they start."""
    exact = _yaw_exact(scene)
    out = list(actions)
    k = 0
    while k < len(out):
        if same_pose(out[k].from_, out[k].to, exact):
            shorter = _without(out, k, exact)
            if shorter is not None:
                out = shorter
                continue
        k += 1
    return out


def necessary_actions(scene: Scene, params: Mapping[str, Any], actions: list[Action]
                      ) -> list[Action]:
    """``actions`` with every action dropped that the plan does without (see module doc)."""
    out = drop_no_ops(scene, actions)
    exact = _yaw_exact(scene)
    for i in range(len(out) - 1, -1, -1):
        if i >= len(out):
            continue
        for flip in (False, True):
            candidate = _without(out, i, exact, flip)
            if candidate is None or not _ends_on_goal(scene, params, out, i, candidate):
                break
            if _valid_from(scene, params, _state_before(scene, out, i), candidate[i:]):
                out = candidate
                break
    return out

