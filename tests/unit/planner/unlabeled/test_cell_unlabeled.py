"""Unlabeled planning, its baseline and retrieval in the work cell's geometry."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

from msgs_py import BlockPose, Goal, GoalSlot, GridSpec, MessageError, Pose2D, Scene, Workspace
from nodes.common.scenes import random_scene
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import goal_kind, plan_goal
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.labeled.plan_labeled import plan_scene
from nodes.planner.outcome import PlanOutcome
from nodes.planner.unlabeled import portfolio
from nodes.planner.unlabeled.baseline import assign_slots, plan_assignment
from nodes.planner.unlabeled.cell_geometry import CellSites
from nodes.planner.unlabeled.cell_transfers import realize
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.goal_check import unfilled_slots
from nodes.planner.unlabeled.plan_unlabeled import plan_unlabeled
from nodes.planner.unlabeled.retrieval import plan_retrieval
from nodes.planner.unlabeled.rpg import build_rpg

S = 0.0508
PITCH = S + 0.003
WS = Workspace(0.45, 0.95, -0.25, 0.25)
CONFIG = PlannerConfig(budget_s=30.0)


def grid_goal(rows: int, cols: int, labeled: bool) -> Goal:
    return Goal(grid=GridSpec(rows, cols, (0.70, 0.0), 0.0, 0.003), labeled=labeled)


def space_for(blocks, goal=None) -> CellSites:
    scene = Scene(WS, S, tuple(blocks), goal)
    return CellSites(PlanContext.for_scene(scene, CONFIG))


def test_a_slot_walled_in_on_both_axes_is_entered_by_place_and_push():
    # Slot at the centre, neighbours on +x and +y: no grasp axis has room at the slot, so
    # the only way in is to set the block down on a push line (from -x or -y) and push.
    sp = space_for([])
    slot = sp.add_site(Pose2D(0.70, 0.0, 0.0))
    east = sp.add_site(Pose2D(0.70 + PITCH, 0.0, 0.0))
    north = sp.add_site(Pose2D(0.70, PITCH, 0.0))
    start = sp.add_site(Pose2D(0.55, -0.18, 0.3))
    t = sp.transfer(start, slot, frozenset({east, north}))
    assert t is not None and t.n_actions == 2
    assert [step.kind for step in t.recipe] == ["pick_place", "push"]
    # The same move with the neighbours gone is one pick-and-place.
    assert sp.transfer(start, slot, frozenset()).n_actions == 1
    # In a graph holding all four sites the transfer only goes one way: the push cannot be
    # undone (the fingers would need room behind the block, where the neighbours are).
    rpg = build_rpg(sp, [slot, east, north, start])
    assert rpg.best[(start, slot)].n_actions == 2 and (slot, start) not in rpg.best


def test_realised_pick_place_keeps_the_grasp_axis_the_transfer_chose():
    sp = space_for([])
    a = sp.add_site(Pose2D(0.6, 0.0, 0.2))
    b = sp.add_site(Pose2D(0.8, 0.1, 0.0))
    t = sp.transfer(a, b, frozenset())
    # The block actually stands turned by 90 degrees from the site's yaw: same footprint.
    actions, end = realize(t, 7, Pose2D(0.6, 0.0, 0.2 + math.pi / 2))
    [act] = actions
    step = t.recipe[0]
    pick_axis = act.from_.theta + act.grasp * math.pi / 2
    place_axis = act.to.theta + act.grasp * math.pi / 2
    assert abs(math.remainder(pick_axis - (0.2 + step.axis_from * math.pi / 2), math.pi)) < 1e-9
    assert abs(math.remainder(place_axis - step.axis_to * math.pi / 2, math.pi)) < 1e-9
    assert abs(math.remainder(end.theta, math.pi / 2)) < 1e-9


def test_unlabeled_plan_is_strictly_shorter_than_the_labeled_one():
    # Six blocks already stand on slots of a 3x3 goal, but not on "their" labeled slots
    # (slot k belongs to the k-th smallest id); three more are scattered. Unlabeled: only the
    # three scattered ones (and maybe a neighbour, to make room) move. Labeled: the six must
    # be permuted too.
    slots = grid_goal(3, 3, False).slot_poses(S)
    on = [8, 7, 6, 5, 1, 0]  # slot of blocks 0..5
    blocks = [BlockPose(i, slots[k].x, slots[k].y, 0.0) for i, k in enumerate(on)]
    blocks += [BlockPose(6, 0.52, -0.20, 0.4), BlockPose(7, 0.88, 0.20, -0.7),
               BlockPose(8, 0.52, 0.20, 1.0)]
    unlabeled = Scene(WS, S, tuple(blocks), grid_goal(3, 3, False))
    labeled = unlabeled.with_goal(grid_goal(3, 3, True))
    u = plan_unlabeled(unlabeled, CONFIG, UnlabeledConfig(b=2))
    lab = plan_scene(labeled, CONFIG)
    assert u.ok, u.error
    assert validate_plan(u.plan).ok
    assert lab.ok, lab.error
    # Three slots to fill, two of them walled in (one push each); the labeled plan must also
    # bring the six blocks to the slots of their ids.
    assert len(u.plan.actions) <= 7 < len(lab.plan.actions)


@pytest.mark.parametrize("b", [1, 3])
def test_random_blocks_fill_a_dense_grid(b):
    scene = random_scene(9, 0.2, seed=3, labeled=False)
    out = plan_unlabeled(scene, CONFIG, UnlabeledConfig(b=b))
    assert out.ok, out.error
    report = validate_plan(out.plan)
    assert report.ok
    assert unfilled_slots(scene, report.final.values(), 0.002, 0.035) == []
    assert out.metrics["actions"] <= out.metrics["actions_raw"]
    assert out.plan.planner == "pebble_graphs" and out.plan.params["unlabeled.b"] == b


def test_surplus_blocks_stay_free():
    slots = grid_goal(1, 2, False).slot_poses(S)
    blocks = [BlockPose(0, slots[0].x, slots[0].y, 0.0), BlockPose(1, 0.55, 0.2, 0.5),
              BlockPose(2, 0.85, -0.2, 0.1)]
    scene = Scene(WS, S, tuple(blocks), grid_goal(1, 2, False))
    out = plan_unlabeled(scene, CONFIG, UnlabeledConfig())
    assert out.ok, out.error
    assert len(out.plan.actions) == 1 and out.plan.actions[0].block in (1, 2)


def test_unlabeled_planner_refuses_other_goals():
    scene = random_scene(4, 0.2, seed=0, labeled=True)
    with pytest.raises(MessageError, match="labeled"):
        plan_unlabeled(scene, CONFIG, UnlabeledConfig())


def plus_cluster(arm: int = 1) -> tuple[list[BlockPose], int]:
    """A cross of blocks 3 mm apart; the centre one (returned id) has no room for fingers."""
    cells = [(0, 0)] + [(d * k, 0) for d in (-1, 1) for k in range(1, arm + 1)] \
        + [(0, d * k) for d in (-1, 1) for k in range(1, arm + 1)]
    blocks = [BlockPose(i, 0.70 + c * PITCH, 0.0 + r * PITCH, 0.0)
              for i, (c, r) in enumerate(cells)]
    return blocks, 0


@pytest.mark.parametrize("arm", [1, 2])
def test_retrieval_of_a_block_buried_in_the_middle(arm):
    blocks, centre = plus_cluster(arm)
    target = GoalSlot(0.53, 0.20, 0.0, centre)
    scene = Scene(WS, S, tuple(blocks), Goal(slots=(target,)))
    assert goal_kind(scene) == "retrieval"
    out = plan_retrieval(scene, CONFIG, UnlabeledConfig())
    assert out.ok, out.error
    report = validate_plan(out.plan)
    assert report.ok
    end = report.final[centre]
    assert math.hypot(end.x - target.x, end.y - target.y) < 1e-6
    # The centre needs both neighbours on one axis gone, then its own move: three actions.
    assert len(out.plan.actions) == 3
    assert out.plan.actions[-1].block == centre


def test_baseline_assigns_each_slot_its_nearest_block_when_that_is_optimal():
    slots = grid_goal(1, 2, False).slot_poses(S)
    blocks = [BlockPose(5, slots[1].x + 0.1, 0.15, 0.0), BlockPose(9, slots[0].x - 0.1, 0.15, 0)]
    scene = Scene(WS, S, tuple(blocks), grid_goal(1, 2, False))
    assert assign_slots(scene) == {0: 9, 1: 5}
    out = plan_assignment(scene, CONFIG, UnlabeledConfig())
    assert out.ok, out.error
    assert out.plan.planner == "assignment_pirs" and not out.plan.scene.goal.labeled
    assert validate_plan(out.plan).ok


def test_dispatch_routes_each_goal_kind():
    unl = random_scene(4, 0.2, seed=1, labeled=False)
    lab = random_scene(4, 0.2, seed=1, labeled=True)
    assert goal_kind(unl) == "unlabeled" and goal_kind(lab) == "labeled"
    assert plan_goal(unl, CONFIG).plan.planner in ("pebble_graphs", "assignment_pirs")
    assert plan_goal(unl, CONFIG, UnlabeledConfig(method="pebble_graphs")).plan.planner \
        == "pebble_graphs"
    assert plan_goal(unl, CONFIG, UnlabeledConfig(method="assignment")).plan.planner \
        == "assignment_pirs"
    assert plan_goal(lab, CONFIG).plan.planner in ("pirs", "pirs_exact")
    blocks, centre = plus_cluster()
    ret = Scene(WS, S, tuple(blocks), Goal(slots=(GoalSlot(0.53, 0.2, 0.0, centre),)))
    assert plan_goal(ret, CONFIG).plan.planner == "pebble_graphs_retrieval"
    assert plan_goal(ret, CONFIG, UnlabeledConfig(retrieval_method="pirs")).plan.planner in \
        ("pirs", "pirs_exact")


def test_unlabeled_validator_flags_an_empty_slot():
    scene = random_scene(4, 0.2, seed=2, labeled=False)
    out = plan_unlabeled(scene, CONFIG, UnlabeledConfig())
    assert out.ok
    truncated = validate_plan(type(out.plan)(actions=out.plan.actions[:-1],
                                             params=out.plan.params, scene=scene))
    assert any("goal slot" in e and "empty" in e for e in truncated.errors)


def test_buffers_keep_clear_of_blocks_and_slots():
    blocks = [BlockPose(0, 0.70, 0.0, 0.0)]
    sp = space_for(blocks)
    site = sp.add_site(blocks[0].pose)
    found = sp.buffers([site], [site], 3, np.random.default_rng(0))
    assert len(found) == 3
    for k, a in enumerate(found):
        assert not sp.conflicts(a, site)
        assert all(not sp.conflicts(a, b) for b in found[k + 1:])


@pytest.mark.parametrize(("k", "density", "seed"), [(2, 0.3, 0), (3, 0.3, 1), (6, 0.3, 2),
                                                    (8, 0.3, 3), (6, 0.05, 4)])
def test_random_scenes_of_every_size_plan_and_validate(k, density, seed):
    from nodes.bench.unlabeled import bench_scene

    scene = bench_scene(k, density, seed, labeled=False)
    out = plan_goal(scene, CONFIG)
    assert out.ok, out.error
    assert validate_plan(out.plan).ok
    assert out.lower_bound <= len(out.plan.actions) <= 2 * k


def test_a_failed_unlabeled_plan_falls_back_to_the_baseline(monkeypatch):
    from nodes.planner import dispatch
    from nodes.planner.labeled.plan_labeled import PlanOutcome

    def fails(scene, config, ucfg, budget=None, plan_id=None):
        return PlanOutcome(None, 0.01, 4, "no plan: made up")

    monkeypatch.setitem(dispatch.UNLABELED, "pebble_graphs", fails)
    out = plan_goal(random_scene(4, 0.2, seed=1, labeled=False), CONFIG,
                    UnlabeledConfig(method="pebble_graphs"))
    assert out.ok and out.plan.planner == "assignment_pirs" and out.metrics["fallback"] == 1.0


def _outcome(actions: int | None, bound: int = 4) -> PlanOutcome:
    plan = None if actions is None else types.SimpleNamespace(actions=[None] * actions)
    return PlanOutcome(plan, 0.01, bound, "" if plan else "no plan: made up")


@pytest.mark.parametrize(("graphs", "assignment", "chosen", "asked"), [
    (7, 6, "assignment", True), (6, 6, "pebble_graphs", True), (None, 6, "assignment", True),
    (4, 3, "pebble_graphs", False)])  # 4 actions meet the bound: the baseline is not asked
def test_the_portfolio_keeps_the_shorter_plan(monkeypatch, graphs, assignment, chosen, asked):
    calls = []

    def fake(name, actions):
        def planner(scene, config, ucfg, budget=None, plan_id=None):
            calls.append(name)
            return _outcome(actions)
        return planner

    monkeypatch.setattr(portfolio, "plan_unlabeled", fake("pebble_graphs", graphs))
    monkeypatch.setattr(portfolio, "plan_assignment", fake("assignment", assignment))
    out = portfolio.plan_portfolio(random_scene(4, 0.2, seed=1, labeled=False), CONFIG,
                                   UnlabeledConfig())
    assert calls == ["pebble_graphs", "assignment"][:1 + asked]
    assert len(out.plan.actions) == {"pebble_graphs": graphs, "assignment": assignment}[chosen]
    assert out.metrics["portfolio_pebble_graphs"] == (graphs if graphs is not None else -1)
